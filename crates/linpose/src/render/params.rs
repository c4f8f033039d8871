//! Rendering parameters: image size, camera and light, each a plain struct with `Default` and
//! by-value setters named after its fields.

use crate::image_io::MAX_PIXELS;
use crate::{Error, Result};

/// How the camera projects the scene.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Projection {
    /// Parallel projection (the paper's long-distance camera).
    #[default]
    Orthographic,
    /// Pinhole projection from `distance` times the object's bounding radius (> 1; a long lens
    /// is about 5 to 20).
    Perspective {
        /// Distance of the camera from the object's centre, in bounding radii.
        distance: f64,
    },
}

/// The camera: its projection, how much of the frame the object takes, and its roll.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    projection: Projection,
    fill: f64,
    offset: [f64; 2],
    roll: f64,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { projection: Projection::Orthographic, fill: 0.85, offset: [0.0, 0.0], roll: 0.0 }
    }
}

impl Camera {
    /// Default distance of [`Camera::perspective`], in bounding radii.
    pub const PERSPECTIVE_DISTANCE: f64 = 8.0;

    /// A perspective camera at [`Camera::PERSPECTIVE_DISTANCE`].
    pub fn perspective() -> Self {
        Camera::default().projection(Projection::Perspective { distance: Self::PERSPECTIVE_DISTANCE })
    }

    /// Sets the projection.
    pub fn projection(mut self, projection: Projection) -> Self {
        self.projection = projection;
        self
    }

    /// Sets the fraction of the image's smaller side that the object's bounding sphere spans
    /// (in (0, 1]; default 0.85). The object lies inside that sphere at every pose, so it is never
    /// clipped.
    pub fn fill(mut self, fill: f64) -> Self {
        self.fill = fill;
        self
    }

    /// Moves the image of the object by `dx` pixels right and `dy` pixels down (default 0, 0):
    /// the object off the optical axis, as a camera that is not centred on it sees it. Parts
    /// moved out of the frame are lost.
    pub fn offset(mut self, dx: f64, dy: f64) -> Self {
        self.offset = [dx, dy];
        self
    }

    /// Turns the camera by `deg` degrees about its optical axis (default 0): the object's image
    /// turns by `deg` counter-clockwise about the image's centre, as a camera tilted sideways
    /// sees it. The view is rendered with the turned camera (not an image turned afterwards), so
    /// the framing holds at every roll: the object's bounding sphere stays in the frame, and the
    /// corners show the background like the rest of the image. Shading does not change: the
    /// camera turns about the line it looks along, so it sees the same lit surface.
    pub fn roll(mut self, deg: f64) -> Self {
        self.roll = deg;
        self
    }

    /// The roll, degrees.
    pub fn get_roll(&self) -> f64 {
        self.roll
    }

    /// The image offset in pixels (right, down).
    pub fn get_offset(&self) -> [f64; 2] {
        self.offset
    }

    /// The projection.
    pub fn get_projection(&self) -> Projection {
        self.projection
    }

    /// The fill fraction.
    pub fn get_fill(&self) -> f64 {
        self.fill
    }
}

/// The light, fixed in the world: a distant source plus ambient light.
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    azimuth_deg: f64,
    elevation_deg: f64,
    ambient: f64,
    diffuse: f64,
    specular: f64,
    shininess: u32,
}

impl Default for Light {
    /// Up and to the right of a camera at azimuth 0, so shading shows the shape at every pose.
    fn default() -> Self {
        Light { azimuth_deg: 35.0, elevation_deg: 50.0, ambient: 0.3, diffuse: 0.7, specular: 0.0, shininess: 24 }
    }
}

macro_rules! setter {
    ($(#[$doc:meta])* $name:ident: $t:ty) => {
        $(#[$doc])*
        pub fn $name(mut self, value: $t) -> Self {
            self.$name = value;
            self
        }
    };
}

impl Light {
    setter!(
        /// Sets the world azimuth of the direction towards the light, in degrees (the camera
        /// lies at world azimuth 0).
        azimuth_deg: f64
    );
    setter!(
        /// Sets the elevation of the direction towards the light above the turntable plane.
        elevation_deg: f64
    );
    setter!(
        /// Sets the ambient term: the brightness, relative to albedo, of a surface the light
        /// does not reach.
        ambient: f64
    );
    setter!(
        /// Sets the weight of the Lambertian term.
        diffuse: f64
    );
    setter!(
        /// Sets the weight of the Blinn-Phong highlight (0, the default, for none).
        specular: f64
    );
    setter!(
        /// Sets the highlight's exponent (1 to 1024; larger is sharper).
        shininess: u32
    );

    /// World azimuth of the light, degrees.
    pub fn get_azimuth_deg(&self) -> f64 {
        self.azimuth_deg
    }
    /// Elevation of the light, degrees.
    pub fn get_elevation_deg(&self) -> f64 {
        self.elevation_deg
    }
    /// Ambient weight.
    pub fn get_ambient(&self) -> f64 {
        self.ambient
    }
    /// Lambertian weight.
    pub fn get_diffuse(&self) -> f64 {
        self.diffuse
    }
    /// Highlight weight.
    pub fn get_specular(&self) -> f64 {
        self.specular
    }
    /// Highlight exponent.
    pub fn get_shininess(&self) -> u32 {
        self.shininess
    }
}

/// Everything that decides an image besides the object and its pose.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderParams {
    width: u32,
    height: u32,
    supersample: u32,
    camera: Camera,
    light: Light,
    exposure: f64,
    background: f64,
}

impl Default for RenderParams {
    /// The paper's 160 x 120 images, 2 x 2 supersampling, orthographic, default light.
    fn default() -> Self {
        RenderParams { width: 160, height: 120, supersample: 2, camera: Camera::default(), light: Light::default(), exposure: 1.0, background: 0.0 }
    }
}

impl RenderParams {
    setter!(
        /// Sets the image width in pixels.
        width: u32
    );
    setter!(
        /// Sets the image height in pixels.
        height: u32
    );
    setter!(
        /// Sets the samples per pixel along each axis (1 to 4; 2 averages 2 x 2 samples).
        supersample: u32
    );
    setter!(
        /// Sets the camera.
        camera: Camera
    );
    setter!(
        /// Sets the light.
        light: Light
    );
    setter!(
        /// Sets the exposure: every pixel's brightness times this (default 1; in (0, 16]),
        /// clipped to white, as a camera's gain or shutter changes it.
        exposure: f64
    );

    setter!(
        /// Sets the brightness of the background, where no surface is seen (default 0, black;
        /// in [0, 1]): a studio backdrop of gray paper or cloth. The exposure scales it too.
        background: f64
    );

    /// The background's brightness.
    pub fn get_background(&self) -> f64 {
        self.background
    }

    /// The exposure.
    pub fn get_exposure(&self) -> f64 {
        self.exposure
    }

    /// Image width.
    pub fn get_width(&self) -> u32 {
        self.width
    }
    /// Image height.
    pub fn get_height(&self) -> u32 {
        self.height
    }
    /// Samples per pixel along each axis.
    pub fn get_supersample(&self) -> u32 {
        self.supersample
    }
    /// The camera.
    pub fn get_camera(&self) -> &Camera {
        &self.camera
    }
    /// The light.
    pub fn get_light(&self) -> &Light {
        &self.light
    }

    /// Checks every parameter, naming the first one out of range.
    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 || self.width as u64 * self.height as u64 > MAX_PIXELS {
            return Err(Error::invalid("size", format!("{}x{}", self.width, self.height), format!("must be at least 1x1 and at most {MAX_PIXELS} pixels")));
        }
        if !(1..=4).contains(&self.supersample) {
            return Err(Error::invalid("supersample", self.supersample, "must be 1, 2, 3 or 4"));
        }
        let c = &self.camera;
        if !(c.fill > 0.0 && c.fill <= 1.0) {
            return Err(Error::invalid("fill", c.fill, "must be in (0, 1]"));
        }
        if c.offset.iter().any(|v| !(v.is_finite() && v.abs() <= (self.width.max(self.height)) as f64)) {
            return Err(Error::invalid("camera offset", format!("{:?}", c.offset), "must be finite and at most the image's size in pixels"));
        }
        if !(self.exposure.is_finite() && self.exposure > 0.0 && self.exposure <= 16.0) {
            return Err(Error::invalid("exposure", self.exposure, "must be in (0, 16]"));
        }
        if !(0.0..=1.0).contains(&self.background) {
            return Err(Error::invalid("background", self.background, "must be a brightness in [0, 1]"));
        }
        if !c.roll.is_finite() {
            return Err(Error::invalid("roll", c.roll, "must be a finite number of degrees"));
        }
        if let Projection::Perspective { distance } = c.projection {
            if !(distance.is_finite() && distance >= 1.5) {
                return Err(Error::invalid("camera distance", distance, "must be finite and at least 1.5 bounding radii"));
            }
        }
        let l = &self.light;
        for (name, v) in [("light azimuth", l.azimuth_deg), ("light elevation", l.elevation_deg)] {
            if !v.is_finite() {
                return Err(Error::invalid(name, v, "must be a finite number of degrees"));
            }
        }
        for (name, v) in [("ambient", l.ambient), ("diffuse", l.diffuse), ("specular", l.specular)] {
            if !(v.is_finite() && (0.0..=10.0).contains(&v)) {
                return Err(Error::invalid(name, v, "must be in [0, 10]"));
            }
        }
        if !(1..=1024).contains(&l.shininess) {
            return Err(Error::invalid("shininess", l.shininess, "must be in 1..=1024"));
        }
        Ok(())
    }
}
