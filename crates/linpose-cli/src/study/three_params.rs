//! Three pose parameters: a data set of azimuth x elevation x camera roll (the experiment renders
//! it), every method trained on the every-other-value lattice (every second value of each
//! parameter from its smallest) and measured on the other views inside the training range (none
//! extrapolated in a linear parameter): model bytes with the paper's Table 1 terms, training
//! time, time per query, the unseen error (the angle of the relative rotation,
//! [`linpose::PoseSpace::error_deg`], and each parameter's own) and the gross errors with how
//! many the confidence flags. The eigenspace and the refined method keep such a manifold as its
//! knots (docs/method.md, "More than two pose parameters"), so their storage grows with the
//! training views, where with two parameters it is the dense lattice's.
//!
//! Beside it, for the report's Table 1 figure ([`super::table1`]), every method fitted on
//! sub-lattices of the training lattice: its most divided parameter (the azimuth) thinned.

use super::table1::{self, Cost, SizePoint};
use super::tuning::THIN;
use super::{StudyParams, GROSS_ERROR_DEG};
use linpose::dataset::Dataset;
use linpose::eval::{evaluate, EvalOptions};
use linpose::model::PoseModel;
use linpose::pose::ErrorSummary;
use linpose::{Error, Result};
use serde::{Deserialize, Serialize};

/// One method on the three-parameter set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct ThreeParamsRow {
    /// Method name.
    pub method: String,
    /// The method's Table 1 formula.
    pub formula: String,
    /// Storage (bytes, the formula's terms) and time per query on the unseen views (the least
    /// of a few batched runs, [`table1::predict_s`]).
    #[serde(flatten)]
    pub cost: Cost,
    /// Seconds to fit.
    pub fit_s: f64,
    /// Errors over the unseen views inside the training range (degrees: the rotation angle).
    pub unseen: ErrorSummary,
    /// Each parameter's mean error over them (degrees, wrapped for a circular one).
    pub param_mean_deg: Vec<f64>,
    /// How many of them are off by more than [`GROSS_ERROR_DEG`].
    pub gross: usize,
    /// How many of the gross errors the confidence flags.
    pub gross_flagged: usize,
    /// How many of them the confidence flags in all.
    pub flagged: usize,
}

/// The three-parameter study on one object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct ThreeParamsStudy {
    /// The object.
    pub object: String,
    /// Its grid, in words.
    pub grid: String,
    /// Parameter names.
    pub params: Vec<String>,
    /// Image width and height.
    pub size: (u32, u32),
    /// Views in all.
    pub n_views: usize,
    /// Training views (the every-other-value lattice).
    pub n_train: usize,
    /// Unseen views inside the training range: the views measured.
    pub n_unseen: usize,
    /// The training lattice's values of each parameter.
    pub trained: Vec<Vec<f64>>,
    /// One row per method.
    pub rows: Vec<ThreeParamsRow>,
    /// Seconds the section took, making the data included (set by the caller that makes it; 0
    /// from [`run`]).
    pub total_s: f64,
}

/// Each parameter's distinct values in `data`, smallest first.
fn values(data: &Dataset) -> Vec<Vec<f64>> {
    (0..data.space().len())
        .map(|j| {
            let mut v: Vec<f64> = (0..data.len()).map(|i| data.pose(i)[j]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        })
        .collect()
}

/// The every-other-value lattice of `data` (each parameter at its 1st, 3rd, 5th, ... value) and
/// which views lie inside its range (each linear parameter between its trained extremes).
fn lattice(data: &Dataset) -> (Vec<bool>, Vec<bool>) {
    let vals = values(data);
    let index = |j: usize, x: f64| vals[j].iter().position(|&v| v == x).unwrap_or(0);
    let train = (0..data.len()).map(|i| data.pose(i).iter().enumerate().all(|(j, &x)| index(j, x).is_multiple_of(2))).collect();
    let params = data.space().params();
    let inside = (0..data.len())
        .map(|i| {
            data.pose(i).iter().enumerate().all(|(j, &x)| {
                let last_trained = (vals[j].len() - 1) / 2 * 2;
                params[j].period.is_some() || (vals[j][0]..=vals[j][last_trained]).contains(&x)
            })
        })
        .collect();
    (train, inside)
}

/// The sub-lattices of `train` (a mask over `data`) for the Table 1 figure: its parameter with
/// the most trained values taken every [`THIN`] values, the largest first.
fn sub_lattices(data: &Dataset, train: &[bool]) -> Result<Vec<Vec<bool>>> {
    let trained = values(&data.subset(train)?);
    let Some(j) = (0..trained.len()).max_by_key(|&j| trained[j].len()) else { return Ok(vec![]) };
    let count = trained[j].len();
    Ok(THIN
        .iter()
        .filter(|&&f| count.is_multiple_of(f) && count / f >= 2)
        .map(|&f| (0..data.len()).map(|i| train[i] && trained[j].iter().position(|&v| v == data.pose(i)[j]).is_some_and(|k| k.is_multiple_of(f))).collect())
        .collect())
}

/// Runs the study on `data` (three or more pose parameters, `grid` its description): the rows
/// and the points of the Table 1 figure (the main fits' among them). `progress(stage)` is
/// called as each stage starts.
pub(crate) fn run(object: &str, data: &Dataset, grid: &str, p: &StudyParams, progress: &dyn Fn(&str)) -> Result<(ThreeParamsStudy, Vec<SizePoint>)> {
    let (train_mask, inside) = lattice(data);
    let train = data.subset(&train_mask)?;
    let unseen_mask: Vec<bool> = train_mask.iter().zip(&inside).map(|(&t, &i)| i && !t).collect();
    if !unseen_mask.contains(&true) {
        return Err(Error::Dataset {
            path: data.manifest().root().to_path_buf(),
            message: "the three-parameter set has no view inside its training range but off the training lattice".into(),
        });
    }
    let unseen = data.subset(&unseen_mask)?;
    let mut rows = Vec::new();
    let mut points = Vec::new();
    for method in &p.methods {
        progress(&format!("{object}, three parameters: {} fit", method.name()));
        let t0 = std::time::Instant::now();
        let model = method.fit(&train)?;
        let fit_s = t0.elapsed().as_secs_f64();
        progress(&format!("{object}, three parameters: {} eval", method.name()));
        let r = evaluate(&model, &unseen, &EvalOptions::new(0.0, p.seed))?;
        // Timed as the figure's other fits of three parameters are: the least of a few runs.
        let cost = Cost::of(&model, table1::predict_s(&model, &unseen)?, unseen.len());
        points.push(SizePoint { object: object.to_string(), params: data.space().len(), method: r.method.clone(), n_train: r.n_train, cost: cost.clone() });
        let conf = r.confidence.as_ref();
        rows.push(ThreeParamsRow {
            method: r.method.clone(),
            formula: model.method().storage.to_string(),
            cost,
            fit_s,
            unseen: r.unseen.unwrap_or(r.all),
            param_mean_deg: r.param_unseen.as_ref().unwrap_or(&r.param_all).iter().map(|s| s.mean_deg).collect(),
            gross: r.samples.iter().filter(|s| s.error_deg > GROSS_ERROR_DEG).count(),
            gross_flagged: conf.map_or(0, |c| c.gross_flagged),
            flagged: conf.map_or(0, |c| c.flagged),
        });
    }
    // The sub-lattices but the whole one, whose points are the main fits'.
    let subs = sub_lattices(data, &train_mask)?;
    let smaller: Vec<Vec<bool>> = subs.into_iter().filter(|m| m != &train_mask).collect();
    points.extend(table1::sizes(&table1::Sizes { object, data, trainings: &smaller, methods: &p.methods, timed: &unseen }, progress)?);
    let study = ThreeParamsStudy {
        object: object.to_string(),
        grid: grid.to_string(),
        params: data.space().params().iter().map(|q| q.name.clone()).collect(),
        size: (data.spec().width, data.spec().height),
        n_views: data.len(),
        n_train: train.len(),
        n_unseen: unseen.len(),
        trained: values(&train),
        rows,
        total_s: 0.0,
    };
    Ok((study, points))
}

#[cfg(test)]
mod tests {
    use super::*;
    use linpose::image_io::{ColorMode, ImageSpec};
    use linpose::manifest::Manifest;
    use linpose::pose::{Param, PoseSpace};

    /// A data set of blank images on the grid azimuth x elevation x roll.
    fn grid(az: &[f64], el: &[f64], roll: &[f64]) -> Dataset {
        let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0), Param::linear("roll")]).unwrap();
        let mut poses = Vec::new();
        for &e in el {
            for &a in az {
                for &r in roll {
                    poses.extend([e, a, r]);
                }
            }
        }
        let n = poses.len() / 3;
        let images = (0..n).map(|i| format!("{i}.png")).collect();
        let spec = ImageSpec { width: 2, height: 1, color: ColorMode::Gray };
        Dataset::from_features(Manifest::new("x", space, images, poses).unwrap(), spec, vec![0.5; 2 * n]).unwrap()
    }

    #[test]
    fn the_lattice_takes_every_other_value_and_the_range_stops_at_its_last() {
        let az: Vec<f64> = (0..12).map(|i| 30.0 * i as f64).collect();
        let d = grid(&az, &[32.0, 41.0, 50.0, 59.0], &[-30.0, -15.0, 0.0]);
        let (train, inside) = lattice(&d);
        for i in 0..d.len() {
            let [e, a, r] = [d.pose(i)[0], d.pose(i)[1], d.pose(i)[2]];
            assert_eq!(train[i], a % 60.0 == 0.0 && (e == 32.0 || e == 50.0) && r != -15.0, "{e} {a} {r}");
            // Elevation 59 lies beyond the last trained one (50); every roll is within -30..0.
            assert_eq!(inside[i], e <= 50.0, "{e} {a} {r}");
        }
        assert_eq!(train.iter().filter(|&&t| t).count(), 6 * 2 * 2);
        // The azimuth (6 trained values) thinned by 3: every 180 degrees; 5 does not divide 6.
        let subs = sub_lattices(&d, &train).unwrap();
        assert_eq!(subs.len(), 2);
        assert_eq!(subs[0], train);
        for i in 0..d.len() {
            assert_eq!(subs[1][i], train[i] && d.pose(i)[1] % 180.0 == 0.0);
        }
    }
}
