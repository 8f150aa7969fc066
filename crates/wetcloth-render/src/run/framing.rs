//! Camera framing: the camera given on the command line ([`CameraSpec`]), completed by a 3/4
//! view that frames the cloth over the whole run.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use super::input::FrameCheck;
use crate::camera::{Camera, DEFAULT_FOV_Y, FRAMING_PITCH, FRAMING_YAW};
use crate::error::RenderError;
use crate::mesh::{Solid, bounds_of};

/// A camera chosen on the command line; what is left out comes from the automatic framing.
///
/// Written either as `YAW,PITCH[,DISTANCE]` (degrees, degrees, metres), or as `key=value`
/// pairs separated by `;` or spaces, with keys `yaw`, `pitch` (degrees), `distance` (m),
/// `fov` (vertical, degrees), `target=x,y,z` and `eye=x,y,z` (m). Examples: `30,25`,
/// `-60,40,0.8`, `eye=0.4,0.3,0.5;target=0,0,0`, `yaw=90 pitch=15 fov=25`.
/// With `eye`, yaw, pitch and distance are ignored.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraSpec {
    /// Turn about the vertical, degrees (0 looks from +Z towards -Z, positive towards +X).
    pub yaw: Option<f32>,
    /// Elevation above the horizon, degrees.
    pub pitch: Option<f32>,
    /// Distance from the target, m.
    pub distance: Option<f32>,
    /// Point looked at, m.
    pub target: Option<[f32; 3]>,
    /// Eye position, m (overrides yaw, pitch and distance).
    pub eye: Option<[f32; 3]>,
    /// Vertical field of view, degrees.
    pub fov: Option<f32>,
}

impl CameraSpec {
    /// The camera for a scene with bounds `bounds_min..bounds_max` in a frame of width /
    /// height `aspect`.
    pub fn resolve(&self, bounds_min: [f32; 3], bounds_max: [f32; 3], aspect: f32) -> Camera {
        let yaw = self.yaw.map_or(FRAMING_YAW, f32::to_radians);
        let pitch = self.pitch.map_or(FRAMING_PITCH, f32::to_radians);
        let framed = Camera::framing_aspect(bounds_min, bounds_max, yaw, pitch, aspect);
        let target = self.target.unwrap_or(framed.target);
        let mut cam = if let Some(eye) = self.eye {
            let d = glam::Vec3::from(eye)
                .distance(glam::Vec3::from(target))
                .max(1e-4);
            Camera {
                eye,
                target,
                near: d * 0.01,
                far: d * 100.0,
                ..framed
            }
        } else {
            let d = glam::Vec3::from(framed.eye).distance(glam::Vec3::from(framed.target));
            Camera::orbit(target, yaw, pitch, self.distance.unwrap_or(d))
        };
        cam.fov_y = self.fov.map_or(DEFAULT_FOV_Y, f32::to_radians);
        cam
    }
}

fn parse_vec3(key: &str, v: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = v.split(',').map(str::trim).collect();
    let nums: Result<Vec<f32>, _> = parts.iter().map(|p| p.parse::<f32>()).collect();
    match nums {
        Ok(n) if n.len() == 3 && n.iter().all(|x| x.is_finite()) => Ok([n[0], n[1], n[2]]),
        _ => Err(format!(
            "{key}={v:?}: expected three numbers x,y,z in metres"
        )),
    }
}

fn parse_num(key: &str, v: &str) -> Result<f32, String> {
    v.trim()
        .parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{key}={v:?}: expected a number"))
}

impl FromStr for CameraSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        let mut spec = CameraSpec::default();
        if !s.contains('=') {
            let parts: Vec<&str> = s.split(',').collect();
            if !(2..=3).contains(&parts.len()) {
                return Err(format!(
                    "invalid camera {s:?}: expected YAW,PITCH[,DISTANCE] (degrees, degrees, m) \
                     or key=value pairs such as eye=x,y,z;target=x,y,z"
                ));
            }
            spec.yaw = Some(parse_num("yaw", parts[0])?);
            spec.pitch = Some(parse_num("pitch", parts[1])?);
            if let Some(d) = parts.get(2) {
                spec.distance = Some(parse_num("distance", d)?);
            }
        } else {
            for pair in s.split([';', ' ']).filter(|p| !p.trim().is_empty()) {
                let (k, v) = pair.split_once('=').ok_or_else(|| {
                    format!("invalid camera setting {pair:?}: expected key=value")
                })?;
                match k.trim() {
                    "yaw" => spec.yaw = Some(parse_num(k, v)?),
                    "pitch" => spec.pitch = Some(parse_num(k, v)?),
                    "distance" => spec.distance = Some(parse_num(k, v)?),
                    "fov" => spec.fov = Some(parse_num(k, v)?),
                    "target" => spec.target = Some(parse_vec3(k, v)?),
                    "eye" => spec.eye = Some(parse_vec3(k, v)?),
                    other => {
                        return Err(format!(
                            "unknown camera setting {other:?}: use yaw, pitch, distance, fov, \
                             target or eye"
                        ));
                    }
                }
            }
        }
        if spec.distance.is_some_and(|d| d <= 0.0) {
            return Err("camera distance must be > 0 m".into());
        }
        if spec.fov.is_some_and(|f| !(1.0..=170.0).contains(&f)) {
            return Err("camera fov must be 1..=170 degrees".into());
        }
        Ok(spec)
    }
}

impl fmt::Display for CameraSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        let v = |p: [f32; 3]| format!("{},{},{}", p[0], p[1], p[2]);
        if let Some(x) = self.yaw {
            parts.push(format!("yaw={x}"));
        }
        if let Some(x) = self.pitch {
            parts.push(format!("pitch={x}"));
        }
        if let Some(x) = self.distance {
            parts.push(format!("distance={x}"));
        }
        if let Some(x) = self.fov {
            parts.push(format!("fov={x}"));
        }
        if let Some(x) = self.target {
            parts.push(format!("target={}", v(x)));
        }
        if let Some(x) = self.eye {
            parts.push(format!("eye={}", v(x)));
        }
        write!(f, "{}", parts.join(";"))
    }
}

/// One camera for the whole run: `spec` completed by a view that frames the cloth's extent over
/// (up to 64 of) the selected `frames` and the `solids`, for an image of width / height
/// `aspect`.
pub(super) fn frame_run(
    spec: CameraSpec,
    frames: &[(u64, PathBuf)],
    solids: &[Solid],
    aspect: f32,
    check: &mut FrameCheck,
) -> Result<Camera, RenderError> {
    let stride = frames.len().div_ceil(64).max(1);
    let mut corners: Vec<[f32; 3]> = Vec::new();
    for (k, (_, path)) in frames.iter().enumerate() {
        if k % stride == 0 || k + 1 == frames.len() {
            let mesh = check.read(path)?;
            if let Some((lo, hi)) = bounds_of(&mesh.positions) {
                corners.extend([lo, hi]);
            }
        }
    }
    for s in solids {
        let (lo, hi) = s.bounds();
        corners.extend([lo, hi]);
    }
    let (lo, hi) = bounds_of(&corners).unwrap_or(([-0.15, 0.0, -0.15], [0.15, 0.02, 0.15]));
    Ok(spec.resolve(lo, hi, aspect))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_specs_parse_and_resolve() {
        let c: CameraSpec = "30,20,0.8".parse().unwrap();
        assert_eq!(
            (c.yaw, c.pitch, c.distance),
            (Some(30.0), Some(20.0), Some(0.8))
        );
        let cam = c.resolve([-0.1, 0.0, -0.1], [0.1, 0.0, 0.1], 1.5);
        let d = glam::Vec3::from(cam.eye) - glam::Vec3::from(cam.target);
        assert!((d.length() - 0.8).abs() < 1e-5);
        assert!((d.y / d.length() - 20f32.to_radians().sin()).abs() < 1e-5);

        let c: CameraSpec = "eye=0.4,0.3,0.5;target=0,0.01,0 fov=25".parse().unwrap();
        assert_eq!(c.eye, Some([0.4, 0.3, 0.5]));
        let cam = c.resolve([0.0; 3], [0.0; 3], 1.5);
        assert_eq!((cam.eye, cam.target), ([0.4, 0.3, 0.5], [0.0, 0.01, 0.0]));
        assert!((cam.fov_y - 25f32.to_radians()).abs() < 1e-6);
        assert_eq!(c.to_string().parse::<CameraSpec>().unwrap(), c);

        for bad in ["1", "1,2,3,4", "yaw=a", "zoom=2", "eye=1,2", "30,20,-1"] {
            assert!(bad.parse::<CameraSpec>().is_err(), "{bad}");
        }
    }
}
