//! Work over a dataset's files, a thread per core: each worker takes the next item in list order, and the
//! results come back in that order whatever finished first.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// `f` over every item, side by side (a thread per core, at most one per item), results in `items`' order.
/// The workers log where the caller logs (a training run's subscriber is set for its own thread only).
pub fn in_parallel<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let next = AtomicUsize::new(0);
    let out: Vec<Mutex<Option<R>>> = items.iter().map(|_| Mutex::new(None)).collect();
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(items.len());
    let dispatch = tracing::dispatcher::get_default(|d| d.clone());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                tracing::dispatcher::with_default(&dispatch, || loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(item) = items.get(i) else { break };
                    let r = f(item);
                    *out[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
                })
            });
        }
    });
    out.into_iter()
        .map(|r| {
            r.into_inner()
                .unwrap_or_else(|e| e.into_inner())
                .expect("every item is visited")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every item once, results in the items' order; no items, no results.
    #[test]
    fn results_come_back_in_order() {
        let items: Vec<u64> = (0..50).collect();
        let out = in_parallel(&items, |&i| {
            std::thread::sleep(std::time::Duration::from_millis((50 - i) % 7));
            i * i
        });
        assert_eq!(out, items.iter().map(|i| i * i).collect::<Vec<_>>());
        assert!(in_parallel(&[] as &[u8], |_| 0).is_empty());
    }
}
