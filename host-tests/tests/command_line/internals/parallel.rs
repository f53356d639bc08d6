//! `kinecal_cli::compute::parallel` (cli/src/compute/parallel.rs) on its own.

#[test]
fn results_come_in_the_order_of_the_items() {
    let items: Vec<u64> = (0..1000).collect();
    let squares: Vec<u64> = items.iter().map(|x| x * x).collect();
    assert_eq!(
        kinecal_cli::compute::parallel::map_each(&items, |x| x * x),
        squares
    );
    assert!(kinecal_cli::compute::parallel::map_each(&[] as &[u64], |x| *x).is_empty());
    let mut m = items.clone();
    assert_eq!(
        kinecal_cli::compute::parallel::map_each_mut(&mut m, |x| {
            *x += 1;
            *x
        }),
        (1..1001).collect::<Vec<_>>()
    );
    assert_eq!(m, (1..1001).collect::<Vec<_>>());
}

/// `map_each_largest_first` hands the largest items out first (`largest_first`: decreasing
/// size, ties in the items' order) and still returns the results in the items' order.
#[test]
fn the_largest_items_go_first_and_results_keep_the_items_order() {
    use kinecal_cli::compute::parallel::{largest_first, map_each_largest_first};
    let items: Vec<u64> = vec![3, 9, 1, 9, 4, 0, 7];
    assert_eq!(
        largest_first(&items, |x| *x as usize),
        vec![1, 3, 6, 4, 0, 2, 5]
    );
    let squares: Vec<u64> = items.iter().map(|x| x * x).collect();
    assert_eq!(
        map_each_largest_first(&items, |x| *x as usize, |x| x * x),
        squares
    );
    assert!(map_each_largest_first(&[] as &[u64], |x| *x as usize, |x| *x).is_empty());
    let many: Vec<u64> = (0..1000).map(|i| (i * 7919) % 1009).collect();
    let expect: Vec<u64> = many.iter().map(|x| x + 1).collect();
    assert_eq!(
        map_each_largest_first(&many, |x| *x as usize, |x| x + 1),
        expect
    );
}
