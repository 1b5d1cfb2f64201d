//! The one tile driver. Every technique's per-tile work (image tiles, sample passes, the
//! irradiance cache's overture chunks, the animation renderer's blocks) runs through
//! [`drive`]: workers take the next item as soon as they finish one (no barrier between
//! groups), and the caller's thread merges the results strictly in item order while the
//! workers go on. Merging in a fixed order is what keeps an image the same bit for bit for
//! any thread count or schedule.

use crate::control::CancelToken;
use crate::platform::set_flush_denormals;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Condvar, Mutex};

/// Results merged per tile, at most this many tiles ahead of the slowest (bounds the memory
/// finished tiles hold while they wait to be merged in order).
pub(crate) const MERGE_WINDOW: usize = 64;

/// How a drive ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Driven {
    /// Items merged: always a prefix of the items, in order.
    pub merged: usize,
    /// A stop was asked for before every item was merged.
    pub cancelled: bool,
}

/// Worker threads for `threads` (`None`: every core), never more than there are items.
pub(crate) fn worker_count(threads: Option<usize>, items: usize) -> usize {
    threads
        .unwrap_or_else(crate::platform::cores)
        .clamp(1, items.max(1))
}

/// Runs `work` on each of `items` on `threads` workers and hands every result to `merge`
/// with its index, in index order, on the calling thread. At most `window` items are
/// started ahead of the last one merged, which bounds the results waiting for a slow item.
/// Once `cancel` is set no new item starts; the results merged so far are a prefix of the
/// items, and the ones finished after a gap are dropped.
pub(crate) fn drive<T, R>(
    items: &[T],
    threads: Option<usize>,
    window: usize,
    cancel: &CancelToken,
    work: impl Fn(&T) -> R + Sync,
    mut merge: impl FnMut(usize, R),
) -> Driven
where
    T: Sync,
    R: Send,
{
    drive_indexed(
        items.len(),
        threads,
        window,
        cancel,
        |i| work(&items[i]),
        |i, r| {
            merge(i, r);
            Merge::Continue
        },
    )
}

/// What the merging side wants after a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Merge {
    Continue,
    /// Start no more items and merge no more results: the work is complete as it stands
    /// (a time limit reached at the end of a pass, an error to report).
    Stop,
}

/// [`drive`] over the items `0..n` given by index, where `merge` may end the work early
/// ([`Merge::Stop`]): the later items' results are dropped and [`Driven::cancelled`] is
/// not set. This lets one drive run through many passes over an image with no pause
/// between them.
pub(crate) fn drive_indexed<R>(
    n: usize,
    threads: Option<usize>,
    window: usize,
    cancel: &CancelToken,
    work: impl Fn(usize) -> R + Sync,
    mut merge: impl FnMut(usize, R) -> Merge,
) -> Driven
where
    R: Send,
{
    let window = window.max(1);
    let next = AtomicUsize::new(0);
    // The count merged so far, which workers wait on when too far ahead; and whether a
    // worker died or the merge stopped (so that the others stop waiting and starting).
    let merged_count = Mutex::new(0usize);
    let advanced = Condvar::new();
    let failed = AtomicBool::new(false);
    let stopped = AtomicBool::new(false);
    let (send, receive) = mpsc::channel::<(usize, R)>();
    let mut merged = 0;
    std::thread::scope(|scope| {
        let mut workers = 0;
        for _ in 0..worker_count(threads, n) {
            let send = send.clone();
            let (next, merged_count, advanced, failed, stopped, work) =
                (&next, &merged_count, &advanced, &failed, &stopped, &work);
            let halted = move || {
                cancel.is_cancelled()
                    || failed.load(Ordering::Relaxed)
                    || stopped.load(Ordering::Relaxed)
            };
            // A thread the system refuses (no memory for its stack, too many threads) is
            // one worker fewer: the results do not depend on how many there are.
            if spawn_refused(workers) {
                break;
            }
            let spawned = std::thread::Builder::new().spawn_scoped(scope, move || {
                set_flush_denormals();
                let _alarm = Alarm { failed, advanced };
                loop {
                    if halted() {
                        break;
                    }
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= n {
                        break;
                    }
                    let mut m = merged_count.lock().unwrap_or_else(|e| e.into_inner());
                    // A cancel sends no wake-up: look at it now and then while waiting.
                    while i >= *m + window && !halted() {
                        m = advanced
                            .wait_timeout(m, std::time::Duration::from_millis(20))
                            .unwrap_or_else(|e| e.into_inner())
                            .0;
                    }
                    drop(m);
                    if halted() {
                        break;
                    }
                    if send.send((i, work(i))).is_err() {
                        break;
                    }
                }
            });
            if spawned.is_err() {
                break;
            }
            workers += 1;
        }
        drop(send);
        if workers == 0 {
            // Not one thread: the work and the merge on this one, in order.
            for i in 0..n {
                if cancel.is_cancelled() {
                    break;
                }
                let flow = merge(i, work(i));
                merged += 1;
                if flow == Merge::Stop {
                    stopped.store(true, Ordering::Relaxed);
                    break;
                }
            }
            return;
        }
        // Results that arrived before their predecessors, by index - merged.
        let mut waiting: VecDeque<Option<R>> = VecDeque::new();
        'receive: for (i, r) in receive.iter() {
            let slot = i - merged;
            if waiting.len() <= slot {
                waiting.resize_with(slot + 1, || None);
            }
            waiting[slot] = Some(r);
            let before = merged;
            while let Some(Some(_)) = waiting.front() {
                let r = waiting.pop_front().flatten().expect("checked above");
                let flow = merge(merged, r);
                merged += 1;
                if flow == Merge::Stop {
                    stopped.store(true, Ordering::Relaxed);
                    advanced.notify_all();
                    break 'receive;
                }
            }
            if merged != before {
                *merged_count.lock().unwrap_or_else(|e| e.into_inner()) = merged;
                advanced.notify_all();
            }
        }
    });
    Driven {
        merged,
        cancelled: merged < n && !stopped.load(Ordering::Relaxed),
    }
}

#[cfg(test)]
thread_local! {
    /// Tests: how many workers a drive on this thread may start before the system is made to
    /// refuse the next (`None`: no limit).
    static SPAWNS_ALLOWED: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
}

/// Whether to act as if the system refused worker number `started` (tests only).
fn spawn_refused(started: usize) -> bool {
    #[cfg(test)]
    if SPAWNS_ALLOWED
        .get()
        .is_some_and(|allowed| started >= allowed)
    {
        return true;
    }
    let _ = started;
    false
}

/// Wakes the other workers if this one unwinds, so that none waits for its item forever.
struct Alarm<'a> {
    failed: &'a AtomicBool,
    advanced: &'a Condvar,
}

impl Drop for Alarm<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.failed.store(true, Ordering::Relaxed);
            self.advanced.notify_all();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merges_every_item_in_order_for_any_thread_count() {
        let items: Vec<u64> = (0..500).collect();
        for threads in [1, 2, 3, 8] {
            for window in [1, 4, 64] {
                let mut seen = Vec::new();
                let d = drive(
                    &items,
                    Some(threads),
                    window,
                    &CancelToken::new(),
                    |&x| {
                        // Uneven work, so that items finish out of order.
                        std::thread::sleep(std::time::Duration::from_micros(x % 7 * 20));
                        x * x
                    },
                    |i, r| seen.push((i, r)),
                );
                assert_eq!(
                    d,
                    Driven {
                        merged: 500,
                        cancelled: false
                    }
                );
                let expected: Vec<_> = (0..500).map(|i| (i as usize, i * i)).collect();
                assert_eq!(seen, expected, "{threads} threads, window {window}");
            }
        }
    }

    /// Threads the system refuses: with one worker of four the drive goes on with it, with
    /// none the calling thread does the work; either way every item is merged in order.
    #[test]
    fn threads_the_system_refuses_leave_fewer_workers() {
        let items: Vec<u64> = (0..300).collect();
        for allowed in [0, 1] {
            SPAWNS_ALLOWED.set(Some(allowed));
            let mut seen = Vec::new();
            let d = drive(
                &items,
                Some(4),
                8,
                &CancelToken::new(),
                |&x| x * 3,
                |i, r| seen.push((i, r)),
            );
            SPAWNS_ALLOWED.set(None);
            assert_eq!(
                d,
                Driven {
                    merged: 300,
                    cancelled: false
                },
                "{allowed} allowed"
            );
            let expected: Vec<_> = (0..300).map(|i| (i as usize, i * 3)).collect();
            assert_eq!(seen, expected, "{allowed} allowed");
        }
    }

    #[test]
    fn a_cancel_stops_starting_items_and_keeps_a_prefix() {
        let items: Vec<u32> = (0..10_000).collect();
        let cancel = CancelToken::new();
        let mut merged = Vec::new();
        let d = drive(
            &items,
            Some(2),
            16,
            &cancel,
            |&x| {
                if x == 100 {
                    cancel.cancel();
                }
                x
            },
            |i, r| merged.push((i, r)),
        );
        assert!(d.cancelled && d.merged < 200, "{d:?}");
        assert_eq!(merged.len(), d.merged);
        assert!(merged
            .iter()
            .enumerate()
            .all(|(k, &(i, r))| k == i && r as usize == i));
    }

    #[test]
    fn a_stop_from_the_merge_ends_the_work_after_that_item() {
        for threads in [1, 2, 3] {
            let mut merged = Vec::new();
            let d = drive_indexed(
                10_000,
                Some(threads),
                16,
                &CancelToken::new(),
                |i| i * 2,
                |i, r| {
                    merged.push(r);
                    if i == 100 {
                        Merge::Stop
                    } else {
                        Merge::Continue
                    }
                },
            );
            assert_eq!(
                d,
                Driven {
                    merged: 101,
                    cancelled: false
                }
            );
            assert_eq!(merged, (0..=100).map(|i| i * 2).collect::<Vec<_>>());
        }
    }

    #[test]
    fn a_panicking_item_does_not_hang_the_others() {
        let items: Vec<u32> = (0..100).collect();
        let result = std::panic::catch_unwind(|| {
            drive(
                &items,
                Some(2),
                2,
                &CancelToken::new(),
                |&x| {
                    assert!(x != 3, "item 3 fails");
                    x
                },
                |_, _| {},
            )
        });
        assert!(result.is_err());
    }
}
