//! The fixed-size back-propagation network.

use kinecal::identify::bpnn::{hidden_size, Activation, Bpnn, BpnnConfig, BpnnError, DEFAULT_A};

/// A smooth map of [−1, 1]² with outputs of different size and offset.
fn smooth(x: &[f64; 2]) -> [f64; 2] {
    [
        3.0 * (1.5 * x[0]).sin() * x[1].cos() + 10.0,
        0.2 * (x[0] * x[0] - 0.5 * x[1]),
    ]
}

fn grid(n: usize, shift: f64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let mut xs = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let u = |k: usize| -1.0 + 2.0 * (k as f64 + shift) / (n as f64 - 1.0 + 2.0 * shift);
            xs.push([u(i), u(j)]);
        }
    }
    let ys = xs.iter().map(smooth).collect();
    (xs, ys)
}

const H: usize = hidden_size(2, 2, DEFAULT_A);

/// Largest error on held-out points relative to each output's range (6 and 0.3).
fn max_relative_error(net: &Bpnn<f64, 2, H, 2>, xs: &[[f64; 2]], ys: &[[f64; 2]]) -> f64 {
    xs.iter()
        .zip(ys)
        .map(|(x, y)| {
            let p = net.forward(x);
            ((p[0] - y[0]).abs() / 6.0).max((p[1] - y[1]).abs() / 0.3)
        })
        .fold(0.0, f64::max)
}

#[test]
fn hidden_size_follows_the_papers_rule() {
    // round(√(m + n)) + a
    assert_eq!(hidden_size(24, 24, 5), 12); // √48 = 6.93
    assert_eq!(hidden_size(2, 2, 5), 7);
    assert_eq!(hidden_size(1, 1, 1), 2); // √2 = 1.41
    assert_eq!(hidden_size(3, 3, 1), 3); // √6 = 2.45
    assert_eq!(hidden_size(10, 10, 10), 14); // √20 = 4.47
    assert_eq!(hidden_size(6, 6, 0), 3); // √12 = 3.46
}

#[test]
fn learns_a_known_smooth_function() {
    let (xs, ys) = grid(15, 0.0);
    let (tx, ty) = grid(10, 0.37);
    for cfg in [
        BpnnConfig::default(),
        BpnnConfig {
            activation: Activation::Sigmoid,
            ..BpnnConfig::default()
        },
        BpnnConfig {
            learning_rate: 0.1,
            batch: 10,
            ..BpnnConfig::default()
        },
    ] {
        let mut net = Bpnn::<f64, 2, H, 2>::new(cfg, 1).unwrap();
        net.fit_ranges(&xs, &ys).unwrap();
        let start = net.loss(&tx, &ty).unwrap();
        let mut last = f64::INFINITY;
        for _ in 0..1000 {
            last = net.train_epoch(&xs, &ys).unwrap();
        }
        let held_out = net.loss(&tx, &ty).unwrap();
        assert_eq!(net.epochs(), 1000);
        assert!(
            start > 0.1,
            "{cfg:?}: an untrained net is far off ({start})"
        );
        assert!(
            last < 1e-3 && held_out < 1e-3,
            "{cfg:?}: training {last}, held-out {held_out}"
        );
        let worst = max_relative_error(&net, &tx, &ty);
        assert!(
            worst < 0.05,
            "{cfg:?}: worst held-out error {worst} of the range"
        );
    }
}

#[test]
fn same_seed_same_net() {
    let (xs, ys) = grid(8, 0.0);
    let train = |seed: u64| {
        let mut net = Bpnn::<f64, 2, H, 2>::new(BpnnConfig::default(), seed).unwrap();
        net.fit_ranges(&xs, &ys).unwrap();
        for _ in 0..20 {
            net.train_epoch(&xs, &ys).unwrap();
        }
        net.forward(&[0.3, -0.7]).map(f64::to_bits)
    };
    assert_eq!(train(4), train(4));
    assert_ne!(train(4), train(5));
}

#[test]
fn constant_outputs_and_ranges() {
    // A target component that never changes must be predicted exactly, without dividing by 0.
    let (xs, _) = grid(5, 0.0);
    let ys: Vec<[f64; 1]> = xs.iter().map(|_| [7.5]).collect();
    let mut net = Bpnn::<f64, 2, 3, 1>::new(BpnnConfig::default(), 2).unwrap();
    net.fit_ranges(&xs, &ys).unwrap();
    for _ in 0..200 {
        net.train_epoch(&xs, &ys).unwrap();
    }
    let p = net.forward(&[0.5, 0.5])[0];
    assert!((p - 7.5).abs() < 1e-3, "{p}");
    assert_eq!(
        net.set_ranges(&[0.0, 1.0], &[1.0, 0.0], &[0.0], &[1.0])
            .unwrap_err(),
        BpnnError::NonFinite
    );
    assert_eq!(
        net.set_ranges(&[0.0, f64::NAN], &[1.0, 1.0], &[0.0], &[1.0])
            .unwrap_err(),
        BpnnError::NonFinite
    );
}

#[test]
fn bad_input_is_refused_and_divergence_undone() {
    assert_eq!(
        Bpnn::<f64, 0, 3, 1>::new(BpnnConfig::default(), 0).unwrap_err(),
        BpnnError::Empty
    );
    for cfg in [
        BpnnConfig {
            learning_rate: 0.0,
            ..BpnnConfig::default()
        },
        BpnnConfig {
            learning_rate: f64::NAN,
            ..BpnnConfig::default()
        },
        BpnnConfig {
            momentum: 1.0,
            ..BpnnConfig::default()
        },
        BpnnConfig {
            batch: 0,
            ..BpnnConfig::default()
        },
    ] {
        assert_eq!(
            Bpnn::<f64, 2, 3, 1>::new(cfg, 0).unwrap_err(),
            BpnnError::Config
        );
    }
    let (xs, ys) = grid(6, 0.0);
    let mut net = Bpnn::<f64, 2, H, 2>::new(BpnnConfig::default(), 3).unwrap();
    net.fit_ranges(&xs, &ys).unwrap();
    assert_eq!(
        net.train_epoch(&xs, &ys[..5]).unwrap_err(),
        BpnnError::Shape
    );
    assert_eq!(net.train_epoch(&[], &[]).unwrap_err(), BpnnError::Shape);
    let mut bad = ys.clone();
    bad[2][1] = f64::INFINITY;
    assert_eq!(
        net.train_epoch(&xs, &bad).unwrap_err(),
        BpnnError::NonFinite
    );
    assert_eq!(net.fit_ranges(&xs, &bad).unwrap_err(), BpnnError::NonFinite);

    // A step size far too large blows the weights up: the epoch is undone.
    net.set_config(BpnnConfig {
        learning_rate: kinecal::identify::bpnn::MAX_LEARNING_RATE,
        ..BpnnConfig::default()
    })
    .unwrap();
    let before = net.forward(&[0.1, 0.2]);
    let epochs = net.epochs();
    assert_eq!(net.train_epoch(&xs, &ys).unwrap_err(), BpnnError::Diverged);
    assert_eq!(net.forward(&[0.1, 0.2]), before);
    assert_eq!(net.epochs(), epochs);
    // And the net still trains normally afterwards.
    net.set_config(BpnnConfig::default()).unwrap();
    assert!(net.train_epoch(&xs, &ys).unwrap().is_finite());
}

#[test]
fn trains_in_f32() {
    let (xs, ys) = grid(12, 0.0);
    let xs: Vec<[f32; 2]> = xs.iter().map(|x| x.map(|v| v as f32)).collect();
    let ys: Vec<[f32; 2]> = ys.iter().map(|y| y.map(|v| v as f32)).collect();
    let mut net = Bpnn::<f32, 2, H, 2>::new(BpnnConfig::default(), 1).unwrap();
    net.fit_ranges(&xs, &ys).unwrap();
    let start = net.loss(&xs, &ys).unwrap();
    for _ in 0..500 {
        net.train_epoch(&xs, &ys).unwrap();
    }
    let end = net.loss(&xs, &ys).unwrap();
    assert!(end < 1e-3 && end < 0.01 * start, "{start} → {end}");
}
