//! A method as the registry knows it ([`Method`]): its name, what it is, its settings by name,
//! its Table 1 storage formula, how its models are read back from a file, what its fit needs in
//! memory, and whether it fits from streamed images or from partial statistics. And a method with its parameters, ready to
//! fit ([`MethodSpec`]).
//!
//! Settings by name ([`Settings`]) are how a caller that holds no method's types (the command
//! line, a report, a script) gives parameters: each method reads the names it declares
//! ([`Method::options`]) and refuses any other, so a setting meant for another method is an
//! error, not silently ignored.

use super::footprint::Footprint;
use super::partial_fit::PartialFit;
use super::{AnyModel, Estimator, ModelMeta, PoseModel, TensorSet};
use crate::dataset::Dataset;
use crate::image_io::ColorMode;
use crate::manifest::Manifest;
use crate::{Error, Result};
use std::sync::Arc;

/// Where a method comes from, for a report that sets the paper's claims beside what it ran.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// The paper's own method (Okatani & Deguchi's linear model).
    Paper,
    /// The method the paper measures itself against (Murase & Nayar's parametric eigenspace).
    Baseline,
    /// Beyond the paper.
    Beyond,
}

/// One setting a method takes by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MethodOption {
    /// Its name (`ridge`; on the command line `--ridge`).
    pub name: &'static str,
    /// What its value looks like (`L|auto`), or "" for an on/off switch.
    pub value: &'static str,
    /// One line: what it does and its default.
    pub help: &'static str,
}

/// Fits a model by streaming the training images from disk: `(manifest, colour, settings,
/// progress)` to the model and a line saying how it was fitted.
pub(crate) type StreamFit = fn(&Manifest, ColorMode, &Settings, &(dyn Fn(u64) + Sync)) -> Result<(AnyModel, String)>;

/// A method's fit from images streamed from disk, and how many times it reads each image.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stream {
    /// The fit.
    pub(crate) fit: StreamFit,
    /// Passes over the images of a set of N images of M features (each image read that many
    /// times), for a progress bar.
    pub(crate) passes: fn(usize, usize) -> u64,
}

/// Makes a method's fit from partial statistics ([`crate::partial`]) from its settings.
pub(crate) type PartialFitOf = fn(&Settings) -> Result<Arc<dyn PartialFit>>;

/// Makes a method's fit, as the memory plan ([`crate::memory`]) counts it, from its settings.
pub(crate) type FootprintOf = fn(&Settings) -> Result<Arc<dyn Footprint>>;

/// An estimation method: everything the rest of linpose needs to know of it. Each method's
/// folder defines one, and [`crate::methods::METHODS`] lists them.
#[derive(Debug)]
pub struct Method {
    /// Its name in model files and on the command line.
    pub name: &'static str,
    /// What it is, in one line.
    pub summary: &'static str,
    /// Whose method it is.
    pub origin: Origin,
    /// Its storage in the paper's Table 1 terms, e.g. `MK` (each model gives the terms' values,
    /// [`PoseModel::storage`]).
    pub storage: &'static str,
    /// The settings it takes by name.
    pub options: &'static [MethodOption],
    pub(crate) params: fn(&Settings) -> Result<MethodSpec>,
    pub(crate) load: fn(ModelMeta, &TensorSet) -> Result<AnyModel>,
    /// What its fit with these settings allocates, for the memory plan ([`crate::memory`]).
    pub(crate) footprint: FootprintOf,
    pub(crate) stream: Option<Stream>,
    /// Its fit with these settings from statistics summed over shards of the training set
    /// ([`crate::partial`]), if it has one.
    pub(crate) partial: Option<PartialFitOf>,
}

impl Method {
    /// The method with `settings` (defaults for every setting not given): errors name a setting
    /// the method does not take or a value it cannot read.
    pub fn spec(&'static self, settings: &Settings) -> Result<MethodSpec> {
        (self.params)(settings)
    }

    /// The method with its default parameters.
    pub fn default_spec(&'static self) -> MethodSpec {
        (self.params)(&Settings::default()).expect("every method's defaults are valid settings")
    }

    /// Whether it can fit from images streamed from disk ([`Method::fit_streamed`]).
    pub fn streams(&self) -> bool {
        self.stream.is_some()
    }

    /// Whether it fits from partial statistics summed over shards of the training set and merged
    /// ([`crate::partial`]).
    pub fn merges(&self) -> bool {
        self.partial.is_some()
    }

    /// Fits on the images of `manifest` read from disk in blocks, for training sets larger than
    /// memory; returns the model and a line saying how it was fitted. `progress` is called with
    /// the number of images read since its last call.
    pub fn fit_streamed(&self, manifest: &Manifest, color: ColorMode, settings: &Settings, progress: &(dyn Fn(u64) + Sync)) -> Result<(AnyModel, String)> {
        let stream = self.stream.ok_or_else(|| Error::invalid("method", self.name, "cannot fit from streamed images; fit it in memory"))?;
        (stream.fit)(manifest, color, settings, progress)
    }

    /// How many images [`Method::fit_streamed`] reads for N training images of M features
    /// (each as many times as it passes over them; 0 for a method that does not stream), for a
    /// progress bar.
    pub fn stream_reads(&self, n: usize, m: usize) -> u64 {
        self.stream.map_or(0, |s| (s.passes)(n, m) * n as u64)
    }

    /// Rebuilds a model of this method from a model file's metadata and arrays.
    pub(crate) fn load(&self, meta: ModelMeta, tensors: &TensorSet) -> Result<AnyModel> {
        (self.load)(meta, tensors)
    }
}

/// Settings by name: `(name, value)` pairs as text, e.g. `("ridge", "1e-3")`, `("center",
/// "true")`. [`Method::spec`] turns them into a method's parameters.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Settings {
    values: Vec<(String, String)>,
}

impl Settings {
    /// No settings: every default.
    pub fn new() -> Self {
        Settings::default()
    }

    /// With setting `name` = `value` (a later value for the same name replaces it).
    pub fn set(mut self, name: impl Into<String>, value: impl Into<String>) -> Self {
        let name = name.into();
        self.values.retain(|(n, _)| *n != name);
        self.values.push((name, value.into()));
        self
    }

    /// The settings given, in order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &str)> {
        self.values.iter().map(|(n, v)| (n.as_str(), v.as_str()))
    }

    /// Whether no setting is given.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// A reader of these settings for `method`, which first refuses every name the method does
    /// not declare.
    pub(crate) fn reader(&self, method: &'static Method) -> Result<SettingsReader<'_>> {
        if let Some((name, value)) = self.iter().find(|(n, _)| !method.options.iter().any(|o| o.name == *n)) {
            let takes: Vec<&str> = method.options.iter().map(|o| o.name).collect();
            let reason = match takes.is_empty() {
                true => format!("the {} method takes no settings", method.name),
                false => format!("the {} method does not take it (it takes: {})", method.name, takes.join(", ")),
            };
            return Err(Error::Setting { method: method.name, name: name.to_string(), value: value.to_string(), reason });
        }
        Ok(SettingsReader { method, settings: self })
    }
}

/// Reads one method's settings, each value parsed with an error that names the setting.
pub(crate) struct SettingsReader<'a> {
    method: &'static Method,
    settings: &'a Settings,
}

impl SettingsReader<'_> {
    /// The raw value of `name`, if given.
    pub(crate) fn text(&self, name: &str) -> Option<&str> {
        self.settings.iter().find(|(n, _)| *n == name).map(|(_, v)| v)
    }

    /// An error about the value of `name`.
    pub(crate) fn error(&self, name: &str, value: &str, reason: impl Into<String>) -> Error {
        Error::Setting { method: self.method.name, name: name.to_string(), value: value.to_string(), reason: reason.into() }
    }

    /// `name` parsed as a `T` (a number), if given; `what` says what was expected.
    pub(crate) fn parse<T: std::str::FromStr>(&self, name: &str, what: &str) -> Result<Option<T>> {
        self.text(name).map(|v| v.parse().map_err(|_| self.error(name, v, format!("expected {what}")))).transpose()
    }

    /// An on/off switch: absent or `true`/`false`.
    pub(crate) fn switch(&self, name: &str) -> Result<bool> {
        Ok(self.parse::<bool>(name, "true or false")?.unwrap_or(false))
    }

    /// Refuses `a` and `b` given together.
    pub(crate) fn exclusive(&self, a: &str, b: &str) -> Result<()> {
        match (self.text(a), self.text(b)) {
            (Some(v), Some(_)) => Err(self.error(a, v, format!("cannot be given with {b}"))),
            _ => Ok(()),
        }
    }
}

/// The object-safe face of an [`Estimator`], so a [`MethodSpec`] can hold any method's parameters.
trait DynEstimator: std::fmt::Debug + Send + Sync {
    fn method(&self) -> &'static Method;
    fn fit_any(&self, train: &Dataset) -> Result<AnyModel>;
    fn leave_one_out(&self, train: &Dataset) -> Option<Result<Vec<f64>>>;
}

impl<E: Estimator + std::fmt::Debug + Send + Sync> DynEstimator for E
where
    E::Model: PoseModel,
{
    fn method(&self) -> &'static Method {
        Estimator::method(self)
    }
    fn fit_any(&self, train: &Dataset) -> Result<AnyModel> {
        Ok(AnyModel::new(self.fit(train)?))
    }
    fn leave_one_out(&self, train: &Dataset) -> Option<Result<Vec<f64>>> {
        Estimator::leave_one_out(self, train)
    }
}

/// A method with its parameters: what the experiment and the command line fit without caring
/// which method it is. Made from a method's parameters (`MethodSpec::from(LinearParams::default())`)
/// or from settings by name ([`Method::spec`]).
#[derive(Debug, Clone)]
pub struct MethodSpec(Arc<dyn DynEstimator>);

impl MethodSpec {
    /// The method.
    pub fn method(&self) -> &'static Method {
        self.0.method()
    }

    /// The method's name.
    pub fn name(&self) -> &'static str {
        self.0.method().name
    }

    /// Fits the method on `train`.
    pub fn fit(&self, train: &Dataset) -> Result<AnyModel> {
        self.0.fit_any(train)
    }

    /// The exact leave-one-out estimates on `train`, for a method that has them in closed form
    /// ([`Estimator::leave_one_out`]).
    pub fn leave_one_out(&self, train: &Dataset) -> Option<Result<Vec<f64>>> {
        self.0.leave_one_out(train)
    }
}

impl<E: Estimator + std::fmt::Debug + Send + Sync + 'static> From<E> for MethodSpec {
    fn from(params: E) -> Self {
        MethodSpec(Arc::new(params))
    }
}
