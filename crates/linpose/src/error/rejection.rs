//! Why the normalisation stage cannot normalise an image ([`Rejection`]), as
//! [`Error::Normalize`](super::Error) reports it.

/// Why an image cannot be normalised.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Rejection {
    /// Nothing differs from the background by more than the threshold.
    #[error("no object found: no pixel differs from the background (level {level:.4}) by more than {threshold:.4}")]
    Empty {
        /// The threshold used.
        threshold: f32,
        /// The background level (first channel).
        level: f32,
    },
    /// A training view that holds a second object apart from the first: a region of the
    /// foreground farther from the object than its size and heavy enough not to be a speck.
    #[error("two objects: a second one {gap:.0} pixels from the first with {:.0}% of its weight, where the parts of one object lie within {limit:.0} pixels of its largest part; crop the training images to one object", share * 100.0)]
    SecondObject {
        /// The second object's weight (summed deviation from the background) over the first's.
        share: f64,
        /// The distance between their bounding boxes (pixels).
        gap: f64,
        /// The farthest a part of one object may lie from its largest part (pixels).
        limit: f64,
    },
    /// The object reaches the frame edge while the training views keep it inside.
    #[error("the object touches the frame edge ({}), so part of it may be outside the image and its position and size are unknown; the training views keep it inside the frame", sides_text(sides))]
    TouchesEdge {
        /// Left, right, top, bottom.
        sides: [bool; 4],
    },
    /// The image has a value that is not a finite number.
    #[error("the image has a value that is not a finite number")]
    NotFinite,
    /// A placement asked of `Normalizer::place` that is not a finite position and a positive
    /// radius.
    #[error("cannot place the object at column {}, row {} with radius {}: a finite position and a positive radius are needed", at[0], at[1], at[2])]
    Placement {
        /// The placement asked.
        at: [f64; 3],
    },
    /// The image (or the output) has another number of values than the stage's images.
    #[error("{got} values where the stage's images have {expected}")]
    Size {
        /// Values per image of the stage.
        expected: usize,
        /// Values given.
        got: usize,
    },
}

fn sides_text(s: &[bool; 4]) -> String {
    ["left", "right", "top", "bottom"].iter().zip(s).filter(|(_, &t)| t).map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}
