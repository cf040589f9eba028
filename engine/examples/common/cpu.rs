//! The examples' CPU clock (shared by `#[path]`: Cargo takes no example from this folder).

/// Process CPU time in seconds (user + system, all threads; getrusage's microseconds). NaN on a
/// system without getrusage (Windows): the examples then report wall time only.
pub fn cpu_s() -> f64 {
    #[cfg(unix)]
    {
        // SAFETY: getrusage only writes the struct it is given.
        let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
        unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) };
        let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 * 1e-6;
        t(ru.ru_utime) + t(ru.ru_stime)
    }
    #[cfg(not(unix))]
    {
        f64::NAN
    }
}
