//! The automatic choices on held-out training views: L, the interpolant, the metric, the
//! binning factor, the noisy match and the noise threshold.

use super::*;

#[test]
fn selection_picks_the_least_held_out_error() {
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let c = select::choose(&d, &g, &RefinedParams::default(), 1).unwrap();
    let best = c.scored.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let first = c.scored.iter().find(|s| s.1 == best).unwrap().0;
    assert_eq!(c.components, first);
    // The plain metric is scored too, and a model fitted on these images uses it exactly when
    // it wins.
    let plain = c.plain.expect("the weighted default scores the plain metric");
    assert_eq!(c.least, best.min(plain));
    assert!(c.standard_error > 0.0 && c.standard_error < c.least, "{c:?}");
    let model = RefinedParams::default().bin(1).fit(&d).unwrap();
    assert_eq!(model.settings().plain_error, Some(plain));
    assert_eq!(model.settings().interpolation_variance.is_empty(), plain < best);
    // Unbinned, no candidate's query costs as much as the eigenspace's 20-row product.
    assert!(c.scored.iter().all(|s| s.0 <= 12), "{c:?}");
    assert!(model.components() <= 12, "{}", model.components());
    // Both interpolants are scored on the same folds; the chosen one has the least error (the
    // spline on a tie), and the model fitted on these images interpolates by it.
    assert_eq!(c.by_interpolant.iter().map(|b| b.0).collect::<Vec<_>>(), INTERPOLANTS);
    let least = c.by_interpolant.iter().map(|b| b.1).fold(f64::INFINITY, f64::min);
    assert_eq!(c.least, least);
    assert_eq!(c.interpolant, c.by_interpolant.iter().find(|b| b.1 == least).unwrap().0);
    assert_eq!(model.settings().interpolant, c.interpolant);
    assert_eq!(model.settings().interpolant_selection, c.by_interpolant);
    // Fixed, an interpolant is scored alone, to the same figures.
    for &(i, e) in &c.by_interpolant {
        let f = select::choose(&d, &g, &RefinedParams::default().interpolant(i), 1).unwrap();
        assert_eq!((f.interpolant, &f.by_interpolant[..]), (i, &[(i, e)][..]));
        if i == c.interpolant {
            assert_eq!((&f.scored, f.plain, f.components), (&c.scored, c.plain, c.components));
        }
    }
}

#[test]
fn every_knot_is_held_out_once() {
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let shape = g.shape();
    let folds = both_folds(&d, &g);
    // The first half are the odd knots' folds (one per usable axis), then the even ones'.
    assert_eq!(folds[..folds.len() / 2], folds::folds(&d, &g)[..]);
    for (j, pair) in folds[..folds.len() / 2].iter().zip(&folds[folds.len() / 2..]).enumerate() {
        let axis = (0..shape.len()).filter(|&a| shape[a] >= 4).nth(j).unwrap();
        let circular = d.space().params()[axis].period.is_some();
        let n = shape[axis];
        for (flat, &i) in g.sample_at.iter().enumerate() {
            let k = flat / shape[axis + 1..].iter().product::<usize>() % n;
            let end = !circular && (k == 0 || k == n - 1);
            // Held out in exactly one of the two folds, or (a linear axis's ends) in neither.
            let held = [!pair.0[i], !pair.1[i]];
            assert_eq!(held.iter().filter(|&&h| h).count(), usize::from(!end), "axis {axis} knot {k}");
        }
    }
}

#[test]
fn a_candidate_never_buys_a_smaller_mean_error_with_a_gross_error() {
    // (gross errors, mean error): fewer gross errors first, then the mean.
    assert!(select::better((0, 5.0), (1, 1.0)));
    assert!(!select::better((1, 1.0), (0, 5.0)));
    assert!(select::better((1, 1.0), (1, 2.0)));
    // A tie keeps the first (the smaller L, the spline).
    assert!(!select::better((1, 1.0), (1, 1.0)));
}

#[test]
fn the_one_standard_error_rule_takes_the_cheapest_within_it() {
    // (mean error, its standard error), costliest first.
    assert_eq!(select::coarsest_within(&[(1.0, 0.1), (1.05, 0.2), (1.2, 0.1)]), (1, 0.1));
    assert_eq!(select::coarsest_within(&[(1.0, 0.1), (1.1, 0.2), (1.05, 0.1)]), (2, 0.1));
    // The least's own standard error sets the tolerance; a tie in the least goes to the first.
    assert_eq!(select::coarsest_within(&[(2.0, 0.5), (1.0, 0.0), (1.0, 0.3)]), (2, 0.0));
    assert_eq!(select::coarsest_within(&[(0.5, 0.0), (0.6, 1.0)]), (0, 0.0));
    // Nothing held out (every error infinite): the cheapest; no candidate: index 0.
    assert_eq!(select::coarsest_within(&[(f64::INFINITY, 0.0), (f64::INFINITY, 0.0)]), (1, 0.0));
    assert_eq!(select::coarsest_within(&[]), (0, 0.0));
    assert_eq!(crate::manifold::folds::standard_error(&[1.0]), 0.0);
    // [0, 1, 2]: sample standard deviation 1, over sqrt(3).
    assert!((crate::manifold::folds::standard_error(&[0.0, 1.0, 2.0]) - 1.0 / 3f64.sqrt()).abs() < 1e-15);
    assert_eq!(select::below_eigenspace(1), 12);
    assert_eq!(select::below_eigenspace(2), 20);
    assert_eq!(select::below_eigenspace(4), 20);
}

#[test]
fn the_noisy_match_is_the_least_held_out_error_under_simulated_noise() {
    let d = train_set();
    let model = RefinedParams::default().fit(&d).unwrap();
    let s = model.settings();
    assert!(!s.noise_selection.is_empty(), "the training grid allows held-out folds");
    let best = s.noise_selection.iter().map(|c| c.2).fold(f64::INFINITY, f64::min);
    let first = s.noise_selection.iter().find(|c| c.2 == best).unwrap();
    assert_eq!((s.noise_components, s.noise_weighted), (first.0, first.1));
    assert_eq!(s.coord_variance.len(), s.components);
    // The choice is made on the training views alone: the same data gives the same model.
    let again = RefinedParams::default().fit(&d).unwrap();
    assert_eq!(again.settings(), s);
}

#[test]
fn the_noise_threshold_separates_clean_and_noisy_training_views() {
    let d = train_set();
    let spec = d.spec();
    let (w, h, m) = (spec.width as usize, spec.height as usize, d.n_features());
    let t = select::noise_threshold(&d).unwrap();
    let clean = (0..d.len()).map(|i| crate::pixel_noise::pixel_noise(d.row(i), w, h, 1)).fold(0.0, f64::max);
    assert_eq!(t.clean, clean, "the noisiest clean training view");
    assert!(t.noisy > 2.0 * t.clean, "simulated +-5% noise stands well above the clean views: {t:?}");
    assert!((t.threshold / (t.clean * t.noisy).sqrt() - 1.0).abs() < 1e-12, "{t:?}");
    assert!(t.clean < t.threshold && t.threshold < t.noisy, "{t:?}");
    // Other noise draws at the smallest level land above it too.
    for seed in [1, 2, 3] {
        let mut q = d.features().to_vec();
        crate::pixel_noise::add_uniform_noise(&mut q, m, NOISE_LEVELS[0], seed).unwrap();
        for x in q.chunks_exact(m) {
            assert!(crate::pixel_noise::pixel_noise(x, w, h, 1) > t.threshold);
        }
    }
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    assert_eq!(model.settings().noise_threshold, t.threshold, "the model keeps the threshold");
    // No separation, or nothing measured: the clean maximum (0 turns detection off).
    assert_eq!(select::separating(1e-4, 4e-4), 2e-4);
    assert_eq!(select::separating(4e-4, 1e-4), 4e-4);
    assert_eq!(select::separating(4e-4, f64::INFINITY), 4e-4);
    assert_eq!(select::separating(0.0, 1e-3), 0.0);
}

#[test]
fn the_automatic_binning_factor_is_the_coarsest_within_a_standard_error() {
    let d = train_set();
    let model = RefinedParams::default().auto_bin().fit(&d).unwrap();
    let s = model.settings();
    // 32 x 12 images: by 4 they keep 8 x 3 pixels, so all three candidates are scored.
    let factors: Vec<usize> = s.bin_selection.iter().map(|c| c.0).collect();
    assert_eq!(factors, BIN_CANDIDATES);
    // The coarsest within one standard error of the least (that least's own, recorded).
    let least = s.bin_selection.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    let chosen = s.bin_selection.iter().rev().find(|c| c.1 <= least + s.bin_tolerance).unwrap().0;
    assert_eq!(s.bin, chosen, "{:?} {}", s.bin_selection, s.bin_tolerance);
    let b_least = s.bin_selection.iter().find(|c| c.1 == least).unwrap().0;
    let images = if b_least == 1 { d.clone() } else { binned(&d, b_least) };
    let g = Grid::new(images.space(), images.poses(), images.manifest().images(), images.manifest().root()).unwrap();
    let c = select::choose(&images, &g, &RefinedParams::default().bin(1), b_least).unwrap();
    assert_eq!((c.least, c.standard_error), (least, s.bin_tolerance));
    assert!(s.bin_tolerance > 0.0);
    // Each candidate's score is what the choice of L on its images gives.
    for &(b, e) in &s.bin_selection {
        let fixed = RefinedParams::default().bin(b).fit(&d).unwrap();
        let f = fixed.settings();
        let want = f.selection.iter().map(|c| c.1).chain(f.plain_error).fold(f64::INFINITY, f64::min);
        assert_eq!(e, want, "factor {b}");
        if b == s.bin {
            let test = grid(&[35.0, 55.0], &[7.5, 100.0, 200.0, 352.5]);
            assert_eq!(model.predict(test.features()).unwrap(), fixed.predict(test.features()).unwrap());
        }
    }
    // Too small an image for a factor leaves it out.
    let tiny = binned(&d, 2);
    let t = RefinedParams::default().auto_bin().fit(&tiny).unwrap();
    assert_eq!(t.settings().bin_selection.iter().map(|c| c.0).collect::<Vec<_>>(), [1, 2]);
}
