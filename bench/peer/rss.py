"""Peak resident memory for the peers, measured as `qean bench` measures its own (Linux VmHWM)."""


def reset_peak_rss():
    """Start the peak from the current resident size (Linux >= 4.0; a no-op elsewhere)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def peak_rss_mb():
    """Peak resident memory since the last reset, in MiB (NaN without /proc)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")
