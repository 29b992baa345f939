//! Backend choice at run time: Burn 0.22 selects the backend through its `Device` value
//! (BURN_NOTES), so `--backend` is a match that builds one. flex is the default CPU backend;
//! ndarray (deprecated upstream) is kept for cross-checks behind this crate's `ndarray` cargo
//! feature; wgpu (Vulkan/Metal/GL) needs its `wgpu` feature.

use burn::tensor::Device;

use crate::error::Error;

/// Backend names `device` accepts, and the default one.
pub use qean_config::{Backend, BACKENDS, DEFAULT_BACKEND};

/// The device of a backend; a one-line error for a backend this build lacks or one that cannot start.
pub fn device(backend: Backend) -> Result<Device, Error> {
    match backend {
        Backend::Flex => Ok(Device::flex()),
        Backend::Ndarray => ndarray_device(),
        Backend::Wgpu => wgpu_device(),
    }
}

#[cfg(not(feature = "ndarray"))]
fn ndarray_device() -> Result<Device, Error> {
    Err(Error::Backend(
        "backend `ndarray` is not in this build: rebuild with `--features ndarray`".into(),
    ))
}

#[cfg(feature = "ndarray")]
#[allow(deprecated)] // Still the independent CPU backend to cross-check flex against.
fn ndarray_device() -> Result<Device, Error> {
    Ok(Device::ndarray())
}

/// The device of a backend named on the command line; a one-line error for an unknown name too.
pub fn device_named(name: &str) -> Result<Device, Error> {
    device(name.parse().map_err(Error::Backend)?)
}

/// Makes flex Burn's default device unless `BURN_DEVICE` names one. Burn puts some tensors on
/// `Device::default()` before moving them where they belong (a loaded optimizer state waits there until
/// the next step); in a build with the wgpu feature that default is the GPU, which would start, print
/// driver messages and, on a machine without one, fail, even for a CPU run. Call it at the start of
/// `main`, before any thread exists (it sets an environment variable).
pub fn prefer_cpu_default_device() {
    if std::env::var_os("BURN_DEVICE").is_none() {
        std::env::set_var("BURN_DEVICE", DEFAULT_BACKEND);
    }
}

#[cfg(not(feature = "wgpu"))]
fn wgpu_device() -> Result<Device, Error> {
    Err(Error::Backend(
        "backend `wgpu` is not in this build: rebuild with `--features wgpu`".into(),
    ))
}

#[cfg(feature = "wgpu")]
fn wgpu_device() -> Result<Device, Error> {
    use burn::tensor::{DeviceKind, Tensor};
    // The device is lazy: run one tiny op so a missing adapter or driver fails here, with one
    // line, instead of panicking at the first real tensor.
    let started = std::panic::catch_unwind(|| {
        let device = Device::wgpu(DeviceKind::DefaultDevice);
        let probe = Tensor::<1>::ones([4], &device).sum().into_scalar::<f32>();
        (device, probe)
    });
    match started {
        Ok((device, 4.0)) => Ok(device),
        Ok((_, probe)) => Err(Error::Backend(format!(
            "backend `wgpu` started but computed 1+1+1+1 = {probe}"
        ))),
        Err(panic) => {
            let why = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("unknown error");
            let why = why.lines().next().unwrap_or(why);
            Err(Error::Backend(format!(
                "backend `wgpu` cannot start: {why}"
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Tensor;

    #[test]
    fn cpu_backends_compute() {
        let names: &[&str] = if cfg!(feature = "ndarray") {
            &["flex", "ndarray"]
        } else {
            &["flex"]
        };
        for &name in names {
            let device = device_named(name).unwrap();
            let s = Tensor::<1>::ones([3], &device).sum().into_scalar::<f32>();
            assert_eq!(s, 3.0, "{name}");
        }
    }

    #[test]
    fn unknown_and_missing_backends_are_one_line_errors() {
        let e = device_named("cuda").unwrap_err().to_string();
        assert!(
            e.contains("cuda") && e.contains("flex") && !e.contains('\n'),
            "{e}"
        );
        if !cfg!(feature = "wgpu") {
            let e = device(Backend::Wgpu).unwrap_err().to_string();
            assert!(e.contains("--features wgpu") && !e.contains('\n'), "{e}");
        }
        if !cfg!(feature = "ndarray") {
            let e = device(Backend::Ndarray).unwrap_err().to_string();
            assert!(e.contains("--features ndarray") && !e.contains('\n'), "{e}");
        }
    }
}

/// Held while a job seeds Burn's random stream and draws from it; see [`rng_guard`].
pub struct RngGuard(Option<std::sync::MutexGuard<'static, ()>>);

thread_local! {
    static RNG_HELD: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Burn's CPU and GPU backends keep one random stream per process, and `device.seed` replaces it. A job
/// that seeds it and then draws from it (a training run, a model's initialisation before its weights are
/// loaded) holds this guard throughout, so that two such jobs on threads of one process (the tests, an
/// in-process sweep) cannot interleave their draws and change each other's results. Re-entrant on one
/// thread: a training run that loads another run's model takes it again without waiting on itself.
pub fn rng_guard() -> RngGuard {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    if RNG_HELD.with(|h| h.get()) {
        return RngGuard(None);
    }
    let guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    RNG_HELD.with(|h| h.set(true));
    RngGuard(Some(guard))
}

impl Drop for RngGuard {
    fn drop(&mut self) {
        if self.0.is_some() {
            RNG_HELD.with(|h| h.set(false));
        }
    }
}
