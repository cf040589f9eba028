//! Host work spread over the machine's cores: the same answers, in order, as a plain map.

/// `f(0), ..., f(n - 1)` in order, on up to as many threads as the machine has cores (each
/// thread takes every `threads`-th index; one thread, or one item, runs on the caller's).
pub fn par_map<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get()).min(n);
    if threads <= 1 {
        return (0..n).map(f).collect();
    }
    let f = &f;
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| s.spawn(move || (t..n).step_by(threads).map(|i| (i, f(i))).collect::<Vec<_>>()))
            .collect();
        let mut out: Vec<Option<T>> = (0..n).map(|_| None).collect();
        for h in handles {
            for (i, r) in h.join().expect("a host thread panicked") {
                out[i] = Some(r);
            }
        }
        out.into_iter().map(|r| r.expect("every index computed")).collect()
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn keeps_the_order_of_a_plain_map() {
        for n in [0usize, 1, 2, 7, 100] {
            let got = super::par_map(n, |i| i * i + 1);
            assert_eq!(got, (0..n).map(|i| i * i + 1).collect::<Vec<_>>());
        }
    }
}
