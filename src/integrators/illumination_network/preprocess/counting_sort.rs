//! The stable counting sorts the preprocess shares: counts to starts, the scatter, and a
//! batch's items grouped by key block and slot.

/// A stable counting sort of a batch's items (slot j's are `items[at[j]..at[j + 1]]`; `items`
/// may hold more after the last slot's) into groups: `place(item)` gives its group for the
/// batch's first slot (slot j's group is j further on) and its value. `start` (zeros on
/// entry, one more than the groups) gives on return group g's first index in `start[g]`.
pub(super) fn group_slots<T: Copy, V: Copy + Default>(
    start: &mut [u32],
    items: &[T],
    at: &[usize],
    place: impl Fn(T) -> (usize, V),
) -> Vec<V> {
    for (j, r) in at.windows(2).enumerate() {
        for &x in &items[r[0]..r[1]] {
            start[place(x).0 + j + 1] += 1;
        }
    }
    starts_from_counts(start);
    let mut grouped = vec![V::default(); at.last().map_or(0, |&n| n)];
    let mut next = start.to_vec();
    // A loop per slot (the slot a constant in it).
    for (j, r) in at.windows(2).enumerate() {
        scatter_stably(
            &mut next,
            items[r[0]..r[1]].iter().copied(),
            |x| place(x).0 + j,
            |x| place(x).1,
            &mut grouped,
        );
    }
    grouped
}

/// Counts to starts, in place: `at[g + 1]` holds group g's item count (`at[0]` is 0), and
/// becomes the end of group g (so `at[g]` its start).
pub(crate) fn starts_from_counts(at: &mut [u32]) {
    for i in 1..at.len() {
        at[i] += at[i - 1];
    }
}

/// The scatter of a stable counting sort, shared by the sorts of the preprocess: `at[g]` is
/// the next place of group g in `out` ([`starts_from_counts`]); `value` of every item goes
/// there, in the items' order.
pub(super) fn scatter_stably<T: Copy, V>(
    at: &mut [u32],
    items: impl IntoIterator<Item = T>,
    group_of: impl Fn(T) -> usize,
    value: impl Fn(T) -> V,
    out: &mut [V],
) {
    items.into_iter().for_each(|x| {
        let to = &mut at[group_of(x)];
        out[*to as usize] = value(x);
        *to += 1;
    });
}
