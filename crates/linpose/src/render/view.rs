//! One view of a rendered data set: the render parameters of its pose (roll, light, jitter) and,
//! when the data set has a scene ([`super::scene`]), its background behind the object, the
//! object's mask and its occluders in front.

use super::background::BackgroundDraw;
use super::scene::SceneRecord;
use super::synth::PoseGrid;
use super::{Mesh, RenderParams, Renderer};
use crate::image_io::{ColorMode, ImageSpec};
use crate::Result;

/// One thread's renderer and the buffers of its views' scenes.
#[derive(Debug)]
pub(crate) struct ViewRenderer {
    renderer: Renderer,
    backdrop: Vec<u8>,
    coverage: Vec<u8>,
    mask: Vec<bool>,
}

impl ViewRenderer {
    /// A renderer for views of `params` (checked by the caller).
    pub(crate) fn new(params: &RenderParams) -> Result<Self> {
        Ok(ViewRenderer { renderer: Renderer::new(params)?, backdrop: Vec::new(), coverage: Vec::new(), mask: Vec::new() })
    }

    /// Renders view `i` of `grid` into `out` (gray, `params`' size), in its scene when the grid
    /// has one that is more than a uniform background, and returns the scene's record. With
    /// `mask`, the object's pixels (those it covers any part of) are marked there: the pixels
    /// the occluders are placed over and whose share they hide.
    pub(crate) fn render(
        &mut self,
        mesh: &Mesh,
        grid: &PoseGrid,
        params: &RenderParams,
        i: usize,
        out: &mut [u8],
        mask: Option<&mut [bool]>,
    ) -> Result<Option<SceneRecord>> {
        let (e, a) = grid.pose(i);
        if grid.per_view_params() {
            self.renderer.set_params(&grid.params_of(i, params)?)?;
        }
        let scene = grid.scene().filter(|s| !s.is_plain());
        if scene.is_none() && mask.is_none() {
            self.renderer.render_into(mesh, a, e, out)?;
            return Ok(None);
        }
        let n = out.len();
        let spec = ImageSpec { width: params.get_width(), height: params.get_height(), color: ColorMode::Gray };
        self.coverage.resize(n, 0);
        self.backdrop.resize(n, 0);
        let background = match scene {
            Some(s) if !s.background().is_level() => Some(s.draw_background(i, spec, &mut self.backdrop)),
            _ => None,
        };
        let backdrop = background.as_ref().map(|_| &self.backdrop[..]);
        self.renderer.render_over(mesh, [a, e], backdrop, out, &mut self.coverage)?;
        self.mask.clear();
        self.mask.extend(self.coverage.iter().map(|&c| c > 0));
        if let Some(m) = mask {
            m.copy_from_slice(&self.mask);
        }
        let Some(scene) = scene else { return Ok(None) };
        let occlusion = scene.draw_occluders(i, spec, &self.mask, out);
        let background = background.unwrap_or(BackgroundDraw::Level(params.get_background()));
        Ok(Some(scene.record(&grid.image_name(i), background, occlusion)))
    }
}
