//! The refined eigenspace in the method registry: its entry, its settings by name, and its
//! storage in the paper's Table 1 terms.

use super::{Interpolant, RefinedModel, RefinedParams};
use crate::model::{AnyModel, Method, MethodOption, Origin, PoseModel, Settings, Storage};
use crate::Result;

/// The refined eigenspace in the method registry.
pub(crate) static METHOD: Method = Method {
    name: "refined",
    summary: "beyond the paper: the eigenspace's spline manifold searched continuously, noisy queries detected and matched apart, every setting chosen from held-out training views",
    origin: Origin::Beyond,
    // The view surface and the noisy match's offset surface (2^D slopes per knot each), both at
    // the S coarse points, the noisy scan's three numbers per point, the basis.
    storage: "2 (2^D NL + SL) + 3S + ML + (K + 1) M / b^2 + NK",
    options: &[
        MethodOption { name: "components", value: "L", help: "number of eigenimages L (default: chosen from held-out training views)" },
        MethodOption {
            name: "resolution",
            value: "D",
            help: "report poses on a lattice of D degrees (default 0.5, the eigenspace's manifold step; 0 = the continuous estimate)",
        },
        MethodOption {
            name: "bin",
            value: "B|auto",
            help: "bin the images by B (each pixel the mean of a B x B block) before fitting and before each query (1 keeps them as given), or auto (the default): B among 1, 2 and 4, the coarsest within one standard error of the least held-out error",
        },
        MethodOption {
            name: "interpolant",
            value: "spline|local|auto",
            help: "how the manifold passes between training views: spline (the C2 cubic spline, the eigenspace's), local (each knot's slope from its two neighbours alone), or auto (the default): chosen by the held-out error of the training views",
        },
        MethodOption {
            name: "roll-split",
            value: "P|auto",
            help: "with a camera roll beside elevation and azimuth: split each interval between training rolls into P by training views turned in the image, extra knots of the manifold (1: none), or auto (the default): 2 where turning each training view to the next training roll reproduces the view there",
        },
    ],
    params: |s| Ok(RefinedParams::from_settings(s)?.into()),
    load: |meta, t| Ok(AnyModel::new(RefinedModel::from_parts(meta, t)?)),
    footprint: |s| Ok(std::sync::Arc::new(RefinedParams::from_settings(s)?)),
    stream: None,
    partial: None,
};

impl RefinedParams {
    /// The parameters from settings by name ([`METHOD`]'s options).
    pub(crate) fn from_settings(settings: &Settings) -> Result<Self> {
        let r = settings.reader(&METHOD)?;
        let mut p = RefinedParams::default();
        if let Some(l) = r.parse("components", "a whole number")? {
            p = p.components(l);
        }
        if let Some(d) = r.parse("resolution", "a number of degrees")? {
            p = p.resolution(d);
        }
        match r.text("bin") {
            None | Some("auto") => p = p.auto_bin(),
            Some(v) => p = p.bin(v.parse().map_err(|_| r.error("bin", v, "expected a whole number or 'auto'"))?),
        }
        match r.text("interpolant") {
            None | Some("auto") => p = p.auto_interpolant(),
            Some(v) => p = p.interpolant(v.parse::<Interpolant>().map_err(|_| r.error("interpolant", v, "expected 'spline', 'local' or 'auto'"))?),
        }
        match r.text("roll-split") {
            None | Some("auto") => {}
            Some(v) => p = p.roll_split(v.parse().map_err(|_| r.error("roll-split", v, "expected a whole number or 'auto'"))?),
        }
        Ok(p)
    }
}

impl RefinedModel {
    /// Table 1's terms: D pose parameters, N knots, S coarse points, L eigenimages, M pixels, and
    /// the second look's K components of images binned by b (`second_look`).
    pub(crate) fn table1_storage(&self) -> Storage {
        let (n, l, s, d, m) = (self.knots_len(), self.components(), self.start_len(), self.meta().space.len(), self.meta().spec.features());
        let (k, b) = self.look.as_ref().map_or((0, 1), |s| (s.settings().components, s.settings().bin));
        let look = crate::second_look::numbers(n, k, m, b);
        Storage::new(&[("D", d), ("N", n), ("S", s), ("L", l), ("M", m), ("K", k), ("b", b)], 2 * ((1 << d) * n * l + s * l) + 3 * s + m * l + look)
    }
}
