//! What a model records of how its normalisation was decided ([`StageChoice`]), and what a caller
//! asks for ([`StageRule`]). The choice itself, on held-out training views, is made where the
//! methods are known: [`crate::MethodSpec::fit_with_stage`].

use super::NormalizeParams;
use serde::{Deserialize, Serialize};

/// What training does about the normalisation stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StageRule {
    /// Chosen on held-out training views among off, brightness, geometry and all
    /// ([`crate::MethodSpec::fit_with_stage`]).
    #[default]
    Auto,
    /// As given: [`NormalizeParams::OFF`] for none.
    Fixed(NormalizeParams),
}

impl StageRule {
    /// `auto`, or a choice's name ([`NormalizeParams::name`]).
    pub fn from_name(name: &str) -> crate::Result<Self> {
        match name {
            "auto" => Ok(StageRule::Auto),
            n => NormalizeParams::from_name(n)
                .map(StageRule::Fixed)
                .map_err(|_| crate::Error::invalid("normalisation", name, "expected auto, off, geometry, brightness or all")),
        }
    }

    /// Whether images may go through a stage: chosen, or fixed to one.
    pub fn normalises(&self) -> bool {
        !matches!(self, StageRule::Fixed(p) if !p.is_on())
    }

    /// `auto` or the fixed choice's name.
    pub fn name(&self) -> &'static str {
        match self {
            StageRule::Auto => "auto",
            StageRule::Fixed(p) => p.name(),
        }
    }
}

/// One candidate's score on the held-out training views.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateScore {
    /// The candidate: `off`, `brightness`, `geometry` or `all`.
    pub stage: String,
    /// Clean held-out views estimated more than [`crate::confidence::GROSS_DEG`] off (`None`
    /// when the candidate could not be scored).
    pub gross: Option<usize>,
    /// The clean views' mean error, degrees.
    pub mean_deg: Option<f64>,
    /// The mean error over the clean and the noisy views together, degrees: the score.
    pub pooled_deg: Option<f64>,
    /// The standard error of that mean.
    pub standard_error: Option<f64>,
    /// Its gross errors and mean error on the held-out views with each of
    /// [`StageChoice::noise_levels`] added.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub noisy: Vec<NoisyScore>,
    /// Why it could not be scored: the stage refused a training view, or the method could not be
    /// fitted on a fold.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
}

impl CandidateScore {
    /// A candidate that could not be scored, and why.
    pub fn refused(stage: &str, why: impl Into<String>) -> Self {
        CandidateScore {
            stage: stage.into(),
            gross: None,
            mean_deg: None,
            pooled_deg: None,
            standard_error: None,
            noisy: Vec::new(),
            refused: Some(why.into()),
        }
    }
}

/// A candidate's score on noisy held-out views.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoisyScore {
    /// Views estimated more than [`crate::confidence::GROSS_DEG`] off.
    pub gross: usize,
    /// Their mean error, degrees.
    pub mean_deg: f64,
}

/// How a model's normalisation was decided, for the record: the model file keeps it and `train`
/// prints it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageChoice {
    /// What the rule was: `auto`, or the choice given.
    pub rule: String,
    /// What was chosen: `off`, `brightness`, `geometry` or `all`.
    pub chosen: String,
    /// The held-out training views each candidate was scored on (0 when not scored).
    pub held_out_views: usize,
    /// The pixel noise amplitudes added to the held-out views for the noisy scores.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub noise_levels: Vec<f64>,
    /// Every candidate's score, the simplest first (empty when the rule fixed the choice).
    pub scores: Vec<CandidateScore>,
    /// Why the choice fell to `off` without scores, if it did (too few training views to hold
    /// any out, or images that are streamed rather than held in memory).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl StageChoice {
    /// A choice fixed by the caller.
    pub fn fixed(p: NormalizeParams) -> Self {
        StageChoice { rule: p.name().into(), chosen: p.name().into(), held_out_views: 0, noise_levels: Vec::new(), scores: Vec::new(), note: None }
    }

    /// Off without scores, because of `note` (the rule was `auto`).
    pub fn off(note: impl Into<String>) -> Self {
        StageChoice { rule: "auto".into(), chosen: "off".into(), held_out_views: 0, noise_levels: Vec::new(), scores: Vec::new(), note: Some(note.into()) }
    }

    /// What was chosen.
    pub fn params(&self) -> NormalizeParams {
        NormalizeParams::from_name(&self.chosen).unwrap_or(NormalizeParams::OFF)
    }

    /// One line saying what was chosen and why, for `train` to print.
    pub fn describe(&self) -> String {
        if self.rule != "auto" {
            return format!("normalisation: {} (as asked)", self.chosen);
        }
        if let Some(note) = &self.note {
            return format!("normalisation: {} ({note})", self.chosen);
        }
        let scores: Vec<String> = self
            .scores
            .iter()
            .map(|s| match (&s.refused, s.pooled_deg, s.standard_error) {
                (Some(r), _, _) => format!("{} not possible: {r}", s.stage),
                (None, Some(m), Some(e)) => format!("{} {m:.3} +- {e:.3}", s.stage),
                _ => format!("{} not scored", s.stage),
            })
            .collect();
        let noise: Vec<String> = self.noise_levels.iter().map(|a| format!("+-{}%", a * 100.0)).collect();
        format!(
            "normalisation: {} (chosen on {} held-out training views, clean and with {} noise; mean error in degrees: {})",
            self.chosen,
            self.held_out_views,
            noise.join(" and "),
            scores.join(", ")
        )
    }
}
