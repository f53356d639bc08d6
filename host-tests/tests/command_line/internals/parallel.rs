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
