//! The recognition rule on distances given by hand; the recognisers on rendered objects are in
//! `tests/recognize.rs`.

use super::*;

#[test]
fn the_nearest_object_wins_and_beyond_its_threshold_the_query_is_unknown() {
    let r = Recognition::from_distances(&[0.5, 0.2, 0.4], &[1.0, 0.3, 1.0]);
    assert_eq!((r.object, r.nearest, r.distance, r.second, r.threshold), (Some(1), 1, 0.2, 0.4, 0.3));
    assert!((r.confidence - 0.75).abs() < 1e-12);
    // Beyond object 1's threshold, though within the others': unknown, the nearest still named.
    let r = Recognition::from_distances(&[0.5, 0.35, 0.4], &[1.0, 0.3, 1.0]);
    assert_eq!((r.object, r.nearest), (None, 1));
    // A tie goes to the lower index, with no margin; one object has no second.
    let r = Recognition::from_distances(&[0.2, 0.2], &[1.0, 1.0]);
    assert_eq!((r.object, r.confidence), (Some(0), 0.0));
    let r = Recognition::from_distances(&[0.2], &[f64::INFINITY]);
    assert_eq!((r.object, r.second, r.confidence), (Some(0), f64::INFINITY, 1.0));
}

#[test]
fn parameters_are_checked_and_named() {
    assert!(RecognizerParams::default().validate().is_ok());
    let e = RecognizerParams::default().components(0).validate().unwrap_err().to_string();
    assert!(e.contains("components"), "{e}");
    let e = RecognizerParams::default().manifold_step(-1.0).validate().unwrap_err().to_string();
    assert!(e.contains("manifold step"), "{e}");
    let e = RecognizerParams::default().unknown(Unknown::Threshold(f64::NAN)).validate().unwrap_err().to_string();
    assert!(e.contains("unknown threshold"), "{e}");
    assert_eq!(RecognizerKind::from_name("linear").unwrap(), RecognizerKind::Linear);
    let e = RecognizerKind::from_name("svm").unwrap_err().to_string();
    assert!(e.contains("universal, linear"), "{e}");
}
