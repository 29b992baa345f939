//! `qean`: music-conditioned 3D dance generation (FACT and QEAN). A thin CLI over the workspace crates.

use clap::Parser;

mod cli;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

extern "C" {
    /// mimalloc's run-time options (linked in by the `mimalloc` crate).
    fn mi_option_set(option: std::ffi::c_int, value: std::ffi::c_long);
}

#[cfg(unix)]
extern "C" {
    /// libc's `signal(2)`.
    fn signal(signum: std::ffi::c_int, handler: usize) -> usize;
}

/// Output piped into a reader that stops early (`qean sweep --dry-run | head`) ends the program quietly,
/// as other Unix tools do, instead of a panic on the closed pipe: SIGPIPE back to its default action
/// (Rust ignores it at start-up).
fn quiet_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: restores the default disposition of SIGPIPE (13) (SIG_DFL = 0) before any thread starts.
    unsafe {
        signal(13, 0);
    }
}

/// `mi_option_purge_delay` in mimalloc's option enum (v2 and v3).
const MI_OPTION_PURGE_DELAY: std::ffi::c_int = 15;

/// Keep freed memory mapped: training allocates and frees the same large tensors every step, and
/// handing pages back to the OS makes the kernel zero them again on the next use (a fifth of a
/// mint-size step; docs/performance.md). `MIMALLOC_PURGE_DELAY` in the environment still wins.
fn keep_freed_memory() {
    if std::env::var_os("MIMALLOC_PURGE_DELAY").is_none() {
        // SAFETY: sets a process-wide integer option; mimalloc reads it when it next purges.
        unsafe { mi_option_set(MI_OPTION_PURGE_DELAY, -1) };
    }
}

fn main() {
    quiet_on_closed_pipe();
    keep_freed_memory();
    qean_models::backend::prefer_cpu_default_device();
    let args = cli::Cli::parse();
    cli::init_logging(args.verbose);
    match cli::run(args) {
        Ok(0) => {}
        Ok(code) => std::process::exit(code),
        Err(e) => {
            // One line, naming the file and the problem; details of the chain joined by ": ".
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}
