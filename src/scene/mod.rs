//! Scene loader: a subset of MuJoCo's MJCF (SPEC §4), so the same file runs in MuJoCo and here.
//!
//! SCM settings come as `<custom><numeric name="scm_..." data="..."/>` (numbers) or
//! `<custom><text name="scm_..." data="..."/>` (names), which MuJoCo ignores. Visual-only
//! elements are skipped; a physics element or attribute we do not model is an error naming the
//! file, the line and the element.

pub mod xml;

use crate::collision::Collider;
use crate::contact::{ContactParams, Dissipation};
use crate::dynamics::spatial::Inertia;
use crate::dynamics::{unit_quat, Body, Joint, JointKind, Tree};
use crate::geometry::{Shape, TriMesh};
use crate::integrate::Integrator;
use crate::model::{Actuator, ActuatorKind, Model, Pair};
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use xml::Element;

/// A scene that could not be loaded: where, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}: <{element}>: {message}")]
pub struct SceneError {
    /// The scene file.
    pub file: String,
    /// 1-based line (0 when the whole file is at fault).
    pub line: usize,
    /// The element at fault.
    pub element: String,
    /// What is wrong.
    pub message: String,
}

/// A loaded scene: the model and what came with it.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The model.
    pub model: Model,
    /// The geoms, per body, as read (for documentation and checks).
    pub geoms: Vec<Geom>,
    /// Things that were accepted but are not modelled exactly (for `scm check`).
    pub warnings: Vec<String>,
    /// Mesh assets the geoms use: name, the `file` attribute as written, and the resolved path.
    pub meshes: Vec<MeshAsset>,
    /// The compiler's mesh folder as written (`meshdir`, else `assetdir`), relative to the
    /// scene file.
    pub meshdir: Option<String>,
}

/// A mesh asset of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAsset {
    /// Asset name (`name`, else the file name without extension).
    pub name: String,
    /// The `file` attribute as written.
    pub file: String,
    /// The file, resolved against the scene's folder and `meshdir`.
    pub path: PathBuf,
    /// The checked mesh (scaled), shared by every geom that uses it.
    pub mesh: Arc<TriMesh>,
    /// Whether a geom uses it.
    pub used: bool,
}

/// A geom as read from the scene, posed in its body's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Geom {
    /// Name (may be generated).
    pub name: String,
    /// Body index.
    pub body: usize,
    /// Shape; `None` for a plane.
    pub shape: Option<Shape>,
    /// Mesh asset name, for mesh geoms.
    pub mesh: Option<String>,
    /// Pose in the body frame.
    pub pose: Isometry3<f64>,
    /// MuJoCo collision bits.
    pub contype: u32,
    /// MuJoCo collision bits.
    pub conaffinity: u32,
}

/// Default spacing between AOPC points when the scene gives no `scm_spacing` (m).
pub const DEFAULT_SPACING: f64 = 0.01;
/// Most AOPC points one body may get, estimated from its geoms' surface area before sampling
/// (a point per `scm_spacing`² of surface, at least three per mesh triangle). A body at the
/// limit takes about 650 MB (about 320 bytes per point with its BVH, see README, Performance)
/// and a pair evaluation at the scenes' ε seconds to minutes; a scene beyond it (a spacing of
/// 1e-9 m, a geom of a kilometre) would exhaust the host's memory, and an allocation failure
/// aborts the host's process: refused with an error instead.
pub const MAX_AOPC_POINTS: f64 = 2e6;

/// Estimated AOPC point count of a shape sampled at `spacing` (m): surface area / spacing², at
/// least three points per mesh triangle (an upper bound for the ellipsoid: its bounding sphere).
fn estimated_points(shape: &Shape, spacing: f64) -> f64 {
    use std::f64::consts::PI;
    let area = match shape {
        Shape::Sphere { radius } => 4.0 * PI * radius * radius,
        Shape::Box { half } => 8.0 * (half.x * half.y + half.y * half.z + half.x * half.z),
        Shape::Capsule {
            radius,
            half_length,
        } => 4.0 * PI * radius * radius + 4.0 * PI * radius * half_length,
        Shape::Cylinder {
            radius,
            half_length,
        } => 2.0 * PI * radius * radius + 4.0 * PI * radius * half_length,
        Shape::Ellipsoid { radii } => 4.0 * PI * radii.max().powi(2),
        Shape::Mesh(m) => {
            let area: f64 = m
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| m.vertices[i as usize]);
                    0.5 * (b - a).cross(&(c - a)).norm()
                })
                .sum();
            return area / (spacing * spacing) + 3.0 * m.triangles.len() as f64;
        }
    };
    area / (spacing * spacing)
}

/// Default internal step when neither `scm_step` nor `<option timestep>` is given (s).
pub const DEFAULT_STEP: f64 = 0.002;

/// Loads a scene file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        file: file.clone(),
        line: 0,
        element: "mujoco".into(),
        message: format!("cannot read the scene: {e}"),
    })?;
    load_str(&text, path)
}

/// Loads a scene from text; `path` names it in errors and anchors relative mesh paths.
pub fn load_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let root = xml::parse(text).map_err(|e| SceneError {
        file: file.clone(),
        line: e.line,
        element: "xml".into(),
        message: e.message,
    })?;
    let mut b = Builder::new(file);
    b.scene(&root)?;
    b.finish()
}

struct Defaults {
    joint: Vec<(String, String)>,
    geom: Vec<(String, String)>,
    general: Vec<(String, String)>,
}

struct Builder {
    file: String,
    degrees: bool,
    meshdir: Option<String>,
    meshes: Vec<MeshAsset>,
    bodies: Vec<Body>,
    joints: Vec<Joint>,
    geoms: Vec<Geom>,
    actuators: Vec<Actuator>,
    gravity: Vector3<f64>,
    timestep: Option<f64>,
    option_integrator: Option<Integrator>,
    numeric: Vec<(String, f64, usize)>,
    text: Vec<(String, String, usize)>,
    defaults: Defaults,
    explicit_pairs: Vec<(String, String, usize)>,
    excludes: Vec<(String, String, usize)>,
    /// Whether each body's inertia came from `<inertial>`.
    explicit_inertia: Vec<bool>,
    warnings: Vec<String>,
}

fn parse_floats(s: &str) -> Option<Vec<f64>> {
    s.split_whitespace()
        .map(|t| t.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect()
}

impl Builder {
    fn new(file: String) -> Self {
        Builder {
            file,
            degrees: true,
            meshdir: None,
            meshes: vec![],
            bodies: vec![Body {
                name: "world".into(),
                parent: None,
                offset: Isometry3::identity(),
                inertia: Inertia {
                    mass: 0.0,
                    com: Vector3::zeros(),
                    rot: Matrix3::zeros(),
                },
                joints: vec![],
                mocap: false,
            }],
            joints: vec![],
            geoms: vec![],
            actuators: vec![],
            gravity: Vector3::new(0.0, 0.0, -9.81),
            timestep: None,
            option_integrator: None,
            numeric: vec![],
            text: vec![],
            defaults: Defaults {
                joint: vec![],
                geom: vec![],
                general: vec![],
            },
            explicit_pairs: vec![],
            excludes: vec![],
            explicit_inertia: vec![false],
            warnings: vec![],
        }
    }

    fn err(&self, el: &Element, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.file.clone(),
            line: el.line,
            element: el.name.clone(),
            message: message.into(),
        }
    }

    /// Rejects attributes outside `allowed` (after dropping visual-only ones).
    fn check_attrs(&self, el: &Element, allowed: &[&str]) -> Result<(), SceneError> {
        const VISUAL: [&str; 6] = ["rgba", "material", "group", "class", "user", "texture"];
        for (k, _) in &el.attrs {
            if k == "class" {
                return Err(self.err(
                    el,
                    "default classes are not supported: use the top-level <default>",
                ));
            }
            if !allowed.contains(&k.as_str()) && !VISUAL.contains(&k.as_str()) {
                return Err(self.err(el, format!("attribute '{k}' is not supported")));
            }
        }
        Ok(())
    }

    fn floats(&self, el: &Element, key: &str, n: usize) -> Result<Option<Vec<f64>>, SceneError> {
        match el.attr(key) {
            None => Ok(None),
            Some(s) => match parse_floats(s) {
                Some(v) if v.len() == n => Ok(Some(v)),
                _ => Err(self.err(el, format!("{key}=\"{s}\": expected {n} finite number(s)"))),
            },
        }
    }

    fn float(&self, el: &Element, key: &str) -> Result<Option<f64>, SceneError> {
        Ok(self.floats(el, key, 1)?.map(|v| v[0]))
    }

    fn vec3(&self, el: &Element, key: &str) -> Result<Option<Vector3<f64>>, SceneError> {
        Ok(self
            .floats(el, key, 3)?
            .map(|v| Vector3::new(v[0], v[1], v[2])))
    }

    /// Orientation from `quat` (w x y z) or `euler` (intrinsic xyz, in the compiler's angle
    /// unit); at most one of them.
    fn orientation(&self, el: &Element) -> Result<UnitQuaternion<f64>, SceneError> {
        for unsupported in ["axisangle", "xyaxes", "zaxis"] {
            if el.attr(unsupported).is_some() {
                return Err(self.err(
                    el,
                    format!("orientation by '{unsupported}' is not supported: use quat or euler"),
                ));
            }
        }
        match (self.floats(el, "quat", 4)?, self.floats(el, "euler", 3)?) {
            (Some(_), Some(_)) => Err(self.err(el, "both quat and euler given")),
            (Some(q), None) => {
                if q.iter().map(|x| x * x).sum::<f64>() < 1e-20 {
                    return Err(self.err(el, "quat is zero"));
                }
                Ok(unit_quat([q[0], q[1], q[2], q[3]]))
            }
            (None, Some(e)) => {
                let k = if self.degrees {
                    std::f64::consts::PI / 180.0
                } else {
                    1.0
                };
                Ok(
                    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), e[0] * k)
                        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), e[1] * k)
                        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), e[2] * k),
                )
            }
            (None, None) => Ok(UnitQuaternion::identity()),
        }
    }

    fn pose(&self, el: &Element) -> Result<Isometry3<f64>, SceneError> {
        let pos = self.vec3(el, "pos")?.unwrap_or_else(Vector3::zeros);
        Ok(Isometry3::from_parts(
            Translation3::from(pos),
            self.orientation(el)?,
        ))
    }

    /// The element with the top-level defaults of its kind filled in.
    fn with_defaults(&self, el: &Element, defaults: &[(String, String)]) -> Element {
        let mut out = el.clone();
        for (k, v) in defaults {
            if out.attr(k).is_none() {
                out.attrs.push((k.clone(), v.clone()));
            }
        }
        out
    }

    fn scene(&mut self, root: &Element) -> Result<(), SceneError> {
        if root.name != "mujoco" {
            return Err(self.err(root, "the root element must be <mujoco>"));
        }
        self.check_attrs(root, &["model"])?;
        // Settings and defaults first: they apply wherever they appear in the file.
        for el in &root.children {
            match el.name.as_str() {
                "compiler" => self.compiler(el)?,
                "option" => self.option(el)?,
                "default" => self.default(el)?,
                "custom" => self.custom(el)?,
                _ => {}
            }
        }
        // Assets next (they may come after the bodies that use them).
        for el in root.children.iter().filter(|e| e.name == "asset") {
            for a in &el.children {
                match a.name.as_str() {
                    "texture" | "material" | "hfield" | "skin" => {}
                    "mesh" => self.mesh_asset(a)?,
                    _ => return Err(self.err(a, "unsupported asset")),
                }
            }
        }
        for el in &root.children {
            match el.name.as_str() {
                "compiler" | "option" | "default" | "custom" => {}
                "worldbody" => {
                    for child in &el.children {
                        self.body_child(child, 0)?;
                    }
                }
                "actuator" => {
                    for a in &el.children {
                        self.actuator(a)?;
                    }
                }
                "contact" => self.contact(el)?,
                "asset" => {}
                "visual" | "statistic" | "size" | "keyframe" | "sensor" | "extension" => {}
                _ => return Err(self.err(el, "unsupported element")),
            }
        }
        Ok(())
    }

    fn compiler(&mut self, el: &Element) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "angle",
                "meshdir",
                "autolimits",
                "inertiafromgeom",
                "texturedir",
                "assetdir",
            ],
        )?;
        match el.attr("angle") {
            None | Some("degree") => self.degrees = true,
            Some("radian") => self.degrees = false,
            Some(a) => {
                return Err(self.err(el, format!("angle=\"{a}\": expected degree or radian")))
            }
        }
        if let Some(d) = el.attr("meshdir").or(el.attr("assetdir")) {
            self.meshdir = Some(d.to_string());
        }
        Ok(())
    }

    fn option(&mut self, el: &Element) -> Result<(), SceneError> {
        self.check_attrs(el, &["timestep", "gravity", "integrator"])?;
        if let Some(t) = self.float(el, "timestep")? {
            if t <= 0.0 {
                return Err(self.err(el, format!("timestep=\"{t}\" must be positive")));
            }
            self.timestep = Some(t);
        }
        if let Some(g) = self.vec3(el, "gravity")? {
            self.gravity = g;
        }
        self.option_integrator = match el.attr("integrator") {
            None => None,
            // MuJoCo's "Euler" is semi-implicit in velocity.
            Some("Euler") => Some(Integrator::SemiImplicitEuler),
            Some("RK4") => Some(Integrator::Rk4),
            // MuJoCo's implicit integrators are implicit in the velocity-dependent forces; SCM's
            // implicit Euler covers that and the stiff contact too.
            Some("implicit") | Some("implicitfast") => Some(Integrator::ImplicitEuler),
            Some(i) => {
                return Err(self.err(el, format!("integrator=\"{i}\" is not a MuJoCo integrator")))
            }
        };
        Ok(())
    }

    fn default(&mut self, el: &Element) -> Result<(), SceneError> {
        if el.attr("class").is_some() {
            return Err(self.err(
                el,
                "default classes are not supported: use the top-level <default>",
            ));
        }
        for d in &el.children {
            let target = match d.name.as_str() {
                "joint" => &mut self.defaults.joint,
                "geom" => &mut self.defaults.geom,
                "general" | "motor" | "position" | "velocity" => &mut self.defaults.general,
                "default" => return Err(self.err(d, "nested default classes are not supported")),
                "site" | "camera" | "light" | "material" | "mesh" => continue,
                _ => return Err(self.err(d, "unsupported default")),
            };
            target.extend(d.attrs.iter().cloned());
        }
        Ok(())
    }

    fn custom(&mut self, el: &Element) -> Result<(), SceneError> {
        for n in &el.children {
            let name = n
                .attr("name")
                .ok_or_else(|| self.err(n, "missing name"))?
                .to_string();
            let data = n.attr("data").ok_or_else(|| self.err(n, "missing data"))?;
            match n.name.as_str() {
                "numeric" => {
                    if name.starts_with("scm_") {
                        let v = parse_floats(data).filter(|v| v.len() == 1).ok_or_else(|| {
                            self.err(
                                n,
                                format!("{name}: data=\"{data}\" must be one finite number"),
                            )
                        })?;
                        self.numeric.push((name, v[0], n.line));
                    }
                }
                "text" => {
                    if name.starts_with("scm_") {
                        self.text.push((name, data.to_string(), n.line));
                    }
                }
                "tuple" => {}
                _ => return Err(self.err(n, "unsupported custom element")),
            }
        }
        Ok(())
    }

    fn body_child(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
        match el.name.as_str() {
            "body" => self.body(el, body),
            "geom" => self.geom(el, body),
            "joint" | "freejoint" if body == 0 => Err(self.err(el, "the world body cannot have joints")),
            "joint" | "freejoint" if self.bodies[body].mocap => {
                Err(self.err(el, format!("mocap body '{}' cannot have joints: its pose comes from the inputs {0}.pos and {0}.quat", self.bodies[body].name)))
            }
            "joint" => self.joint(el, body, false),
            "freejoint" => self.joint(el, body, true),
            "inertial" if body == 0 => Err(self.err(el, "the world body has no inertia")),
            "inertial" => self.inertial(el, body),
            "site" | "camera" | "light" => Ok(()),
            _ => Err(self.err(el, "unsupported element in a body")),
        }
    }

    fn body(&mut self, el: &Element, parent: usize) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "name",
                "pos",
                "quat",
                "euler",
                "childclass",
                "mocap",
                "gravcomp",
            ],
        )?;
        let mocap = match el.attr("mocap") {
            None | Some("false") => false,
            Some("true") => true,
            Some(m) => return Err(self.err(el, format!("mocap=\"{m}\": expected true or false"))),
        };
        if mocap && parent != 0 {
            return Err(self.err(
                el,
                "a mocap body must be a child of the worldbody (MuJoCo's rule)",
            ));
        }
        if parent != 0 && self.bodies[parent].mocap {
            return Err(self.err(el, format!("body inside mocap body '{}': a mocap body cannot have child bodies (put its geoms in it directly)", self.bodies[parent].name)));
        }
        let index = self.bodies.len();
        let name = el
            .attr("name")
            .map(str::to_string)
            .unwrap_or_else(|| format!("body{index}"));
        if self.bodies.iter().any(|b| b.name == name) {
            return Err(self.err(el, format!("body name '{name}' is used twice")));
        }
        let offset = self.pose(el)?;
        self.bodies.push(Body {
            name,
            parent: Some(parent),
            offset,
            inertia: Inertia {
                mass: 0.0,
                com: Vector3::zeros(),
                rot: Matrix3::zeros(),
            },
            joints: vec![],
            mocap,
        });
        self.explicit_inertia.push(false);
        for child in &el.children {
            self.body_child(child, index)?;
        }
        Ok(())
    }

    fn joint(&mut self, el: &Element, body: usize, free: bool) -> Result<(), SceneError> {
        let el = &if free {
            el.clone()
        } else {
            self.with_defaults(el, &self.defaults.joint)
        };
        self.check_attrs(
            el,
            &[
                "name",
                "type",
                "axis",
                "pos",
                "damping",
                "stiffness",
                "frictionloss",
                "armature",
                "range",
                "limited",
                "ref",
                "springref",
            ],
        )?;
        let kind = if free {
            JointKind::Free
        } else {
            match el.attr("type").unwrap_or("hinge") {
                "free" => JointKind::Free,
                "ball" => JointKind::Ball,
                "slide" => JointKind::Slide,
                "hinge" => JointKind::Hinge,
                t => return Err(self.err(el, format!("type=\"{t}\" is not a joint type"))),
            }
        };
        for (key, what) in [
            ("ref", "reference positions"),
            ("springref", "spring reference positions"),
        ] {
            if self.float(el, key)?.is_some_and(|v| v != 0.0) {
                return Err(self.err(el, format!("{key}: {what} other than 0 are not supported")));
            }
        }
        if el.attr("limited") == Some("true") {
            self.warnings.push(format!(
                "{}:{}: joint limits are not modelled by SCM (MuJoCo enforces them)",
                self.file, el.line
            ));
        }
        let axis = self.vec3(el, "axis")?.unwrap_or_else(Vector3::z);
        if axis.norm() < 1e-12 {
            return Err(self.err(el, "axis is zero"));
        }
        let scalar = |key: &str| -> Result<f64, SceneError> {
            let v = self.float(el, key)?.unwrap_or(0.0);
            if v < 0.0 {
                return Err(self.err(el, format!("{key}=\"{v}\" must not be negative")));
            }
            Ok(v)
        };
        if kind == JointKind::Free && self.float(el, "stiffness")?.is_some_and(|k| k != 0.0) {
            return Err(self.err(el, "stiffness on a free joint is not supported (springs act on slide, hinge and ball joints)"));
        }
        let index = self.joints.len();
        let name = match el.attr("name") {
            Some(n) => n.to_string(),
            None if free => self.bodies[body].name.clone(),
            None => format!(
                "{}_joint{}",
                self.bodies[body].name,
                self.bodies[body].joints.len()
            ),
        };
        if self.joints.iter().any(|j| j.name == name) {
            return Err(self.err(el, format!("joint name '{name}' is used twice")));
        }
        let joint = Joint {
            name,
            kind,
            axis: axis.normalize(),
            anchor: self.vec3(el, "pos")?.unwrap_or_else(Vector3::zeros),
            damping: scalar("damping")?,
            stiffness: scalar("stiffness")?,
            frictionloss: scalar("frictionloss")?,
            armature: scalar("armature")?,
            qadr: 0,
            dadr: 0,
            body,
        };
        self.joints.push(joint);
        self.bodies[body].joints.push(index);
        Ok(())
    }

    fn geom(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
        let el = &self.with_defaults(el, &self.defaults.geom);
        self.check_attrs(
            el,
            &[
                "name",
                "type",
                "size",
                "pos",
                "quat",
                "euler",
                "fromto",
                "mass",
                "density",
                "friction",
                "contype",
                "conaffinity",
                "condim",
                "margin",
                "gap",
                "solref",
                "solimp",
                "priority",
                "mesh",
            ],
        )?;
        for ignored in ["margin", "gap", "solref", "solimp", "condim", "priority"] {
            if el.attr(ignored).is_some() {
                self.warnings.push(format!("{}:{}: geom attribute '{ignored}' belongs to MuJoCo's contact model and is ignored by SCM", self.file, el.line));
            }
        }
        if el.attr("friction").is_some() {
            self.warnings.push(format!(
                "{}:{}: per-geom friction is ignored: SCM uses scm_friction for every pair",
                self.file, el.line
            ));
        }
        let size = el.attr("size").and_then(parse_floats).unwrap_or_default();
        let kind = el.attr("type").unwrap_or("sphere");
        let fromto = self.floats(el, "fromto", 6)?;
        // With fromto, the geom runs from one point to the other along its z axis.
        let from_to = match fromto {
            Some(_) if !matches!(kind, "capsule" | "cylinder" | "box" | "ellipsoid") => {
                return Err(self.err(el, format!("fromto does not apply to a {kind}")))
            }
            Some(f) => {
                if el.attr("pos").is_some()
                    || el.attr("quat").is_some()
                    || el.attr("euler").is_some()
                {
                    return Err(self.err(el, "give either fromto or pos/quat/euler, not both"));
                }
                let (a, b) = (
                    Vector3::new(f[0], f[1], f[2]),
                    Vector3::new(f[3], f[4], f[5]),
                );
                let axis = b - a;
                if axis.norm() < 1e-12 {
                    return Err(self.err(el, "fromto: the two points coincide"));
                }
                Some((
                    Isometry3::from_parts(
                        Translation3::from((a + b) * 0.5),
                        crate::geometry::aopc::z_to(&axis.normalize()),
                    ),
                    0.5 * axis.norm(),
                ))
            }
            None => None,
        };
        let need = |n: usize| -> Result<(), SceneError> {
            if size.len() < n || size[..n].iter().any(|&s| s <= 0.0) {
                return Err(self.err(
                    el,
                    format!(
                        "size needs {n} positive number(s), got \"{}\"",
                        el.attr("size").unwrap_or("")
                    ),
                ));
            }
            Ok(())
        };
        // Half-length along z: from fromto, else the size entry at `k`.
        let half_z = |k: usize| -> Result<f64, SceneError> {
            match from_to {
                Some((_, h)) => Ok(h),
                None => {
                    need(k + 1)?;
                    Ok(size[k])
                }
            }
        };
        let mut mesh_name = None;
        let shape = match kind {
            "sphere" => {
                need(1)?;
                Some(Shape::Sphere { radius: size[0] })
            }
            "box" => {
                need(2)?;
                let hz = half_z(2)?;
                Some(Shape::Box {
                    half: Vector3::new(size[0], size[1], hz),
                })
            }
            "capsule" => {
                need(1)?;
                Some(Shape::Capsule {
                    radius: size[0],
                    half_length: half_z(1)?,
                })
            }
            "cylinder" => {
                need(1)?;
                Some(Shape::Cylinder {
                    radius: size[0],
                    half_length: half_z(1)?,
                })
            }
            "ellipsoid" => {
                need(2)?;
                let hz = half_z(2)?;
                Some(Shape::Ellipsoid {
                    radii: Vector3::new(size[0], size[1], hz),
                })
            }
            "mesh" => {
                let name = el.attr("mesh").ok_or_else(|| {
                    self.err(el, "a mesh geom needs mesh=\"NAME\" naming a <mesh> asset")
                })?;
                let asset = self
                    .meshes
                    .iter_mut()
                    .find(|m| m.name == name)
                    .ok_or_else(|| SceneError {
                        file: self.file.clone(),
                        line: el.line,
                        element: el.name.clone(),
                        message: format!("no mesh asset named '{name}'"),
                    })?;
                asset.used = true;
                mesh_name = Some(name.to_string());
                Some(Shape::Mesh(asset.mesh.clone()))
            }
            "plane" => None,
            t @ ("hfield" | "sdf") => {
                return Err(self.err(el, format!("geom type {t} is not supported")))
            }
            t => return Err(self.err(el, format!("type=\"{t}\" is not a geom type"))),
        };
        if el.attr("mesh").is_some() && kind != "mesh" {
            return Err(self.err(
                el,
                format!(
                    "mesh=\"{}\" given for a {kind} geom: add type=\"mesh\"",
                    el.attr("mesh").unwrap_or("")
                ),
            ));
        }
        let pose = match from_to {
            Some((p, _)) => p,
            None => self.pose(el)?,
        };
        let name = el.attr("name").map(str::to_string).unwrap_or_else(|| {
            format!(
                "{}_geom{}",
                self.bodies[body].name,
                self.geoms.iter().filter(|g| g.body == body).count()
            )
        });
        if let Some(shape) = &shape {
            if !self.explicit_inertia[body] && body != 0 {
                let mp = shape.mass_properties();
                let mass = match (self.float(el, "mass")?, self.float(el, "density")?) {
                    (Some(m), _) if m < 0.0 => {
                        return Err(self.err(el, format!("mass=\"{m}\" must not be negative")))
                    }
                    (Some(m), _) => m,
                    (None, Some(d)) if d < 0.0 => {
                        return Err(self.err(el, format!("density=\"{d}\" must not be negative")))
                    }
                    (None, d) => d.unwrap_or(1000.0) * mp.volume,
                };
                let gi = geom_inertia(&mp, mass, &pose);
                self.bodies[body].inertia = self.bodies[body].inertia.add(&gi);
            }
        } else if body != 0 && !self.bodies[body].joints.is_empty() {
            return Err(self.err(el, "a plane can only belong to a static body"));
        }
        let (contype, conaffinity) = (self.bits(el, "contype")?, self.bits(el, "conaffinity")?);
        self.geoms.push(Geom {
            name,
            body,
            shape,
            mesh: mesh_name,
            pose,
            contype,
            conaffinity,
        });
        Ok(())
    }

    /// `<mesh name file scale>`: loads and checks the file at once (paths relative to the scene
    /// file's folder and the compiler's `meshdir`), so that problems name the asset's line.
    fn mesh_asset(&mut self, el: &Element) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "name",
                "file",
                "scale",
                "inertia",
                "maxhullvert",
                "refpos",
                "refquat",
            ],
        )?;
        for unsupported in ["refpos", "refquat"] {
            if el.attr(unsupported).is_some() {
                return Err(self.err(el, format!("{unsupported} is not supported")));
            }
        }
        let file = el
            .attr("file")
            .ok_or_else(|| {
                self.err(
                    el,
                    "a mesh needs file=\"...\" (OBJ or STL); inline vertices are not supported",
                )
            })?
            .to_string();
        let name = el.attr("name").map(str::to_string).unwrap_or_else(|| {
            Path::new(&file)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        });
        if self.meshes.iter().any(|m| m.name == name) {
            return Err(self.err(el, format!("mesh name '{name}' is used twice")));
        }
        let scale = self
            .vec3(el, "scale")?
            .unwrap_or_else(|| Vector3::repeat(1.0));
        if scale.iter().any(|&x| x == 0.0) {
            return Err(self.err(el, "scale has a zero component"));
        }
        let path = mesh_path(Path::new(&self.file), self.meshdir.as_deref(), &file);
        let (mesh, warnings) =
            TriMesh::load(&path, &scale).map_err(|e| self.err(el, e.to_string()))?;
        for w in warnings {
            self.warnings
                .push(format!("{}:{}: {w}", self.file, el.line));
        }
        self.meshes.push(MeshAsset {
            name,
            file,
            path,
            mesh: Arc::new(mesh),
            used: false,
        });
        Ok(())
    }

    fn bits(&self, el: &Element, key: &str) -> Result<u32, SceneError> {
        match el.attr(key) {
            None => Ok(1),
            Some(s) => s
                .parse::<u32>()
                .map_err(|_| self.err(el, format!("{key}=\"{s}\" must be a non-negative integer"))),
        }
    }

    fn inertial(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &["pos", "quat", "euler", "mass", "diaginertia", "fullinertia"],
        )?;
        let mass = self
            .float(el, "mass")?
            .ok_or_else(|| self.err(el, "mass is required"))?;
        if mass <= 0.0 {
            return Err(self.err(el, format!("mass=\"{mass}\" must be positive")));
        }
        let pose = self.pose(el)?;
        let rot = match (
            self.vec3(el, "diaginertia")?,
            self.floats(el, "fullinertia", 6)?,
        ) {
            (Some(d), None) => Matrix3::from_diagonal(&d),
            (None, Some(f)) => Matrix3::new(f[0], f[3], f[4], f[3], f[1], f[5], f[4], f[5], f[2]),
            _ => return Err(self.err(el, "give exactly one of diaginertia and fullinertia")),
        };
        if rot.symmetric_eigenvalues().min() <= 0.0 {
            return Err(self.err(el, "the inertia is not positive definite"));
        }
        let r = pose.rotation.to_rotation_matrix().into_inner();
        self.bodies[body].inertia = Inertia {
            mass,
            com: pose.translation.vector,
            rot: r * rot * r.transpose(),
        };
        self.explicit_inertia[body] = true;
        Ok(())
    }

    fn actuator(&mut self, el: &Element) -> Result<(), SceneError> {
        let el = &self.with_defaults(el, &self.defaults.general);
        self.check_attrs(
            el,
            &[
                "name",
                "joint",
                "gear",
                "kp",
                "kv",
                "ctrlrange",
                "ctrllimited",
                "forcerange",
                "forcelimited",
            ],
        )?;
        if el.attr("forcerange").is_some() && el.attr("forcelimited") != Some("false") {
            return Err(self.err(el, "forcerange is not supported"));
        }
        let jname = el
            .attr("joint")
            .ok_or_else(|| self.err(el, "only joint actuators are supported: joint is required"))?;
        let joint = self
            .joints
            .iter()
            .position(|j| j.name == jname)
            .ok_or_else(|| self.err(el, format!("no joint named '{jname}'")))?;
        if self.joints[joint].kind.nv() != 1 {
            return Err(self.err(
                el,
                format!("joint '{jname}' has more than one degree of freedom"),
            ));
        }
        let gear = match el.attr("gear") {
            None => 1.0,
            Some(s) => match parse_floats(s) {
                Some(v) if !v.is_empty() && v[1..].iter().all(|&x| x == 0.0) => v[0],
                _ => {
                    return Err(
                        self.err(el, format!("gear=\"{s}\": only a scalar gear is supported"))
                    )
                }
            },
        };
        let gain = |key: &str, default: f64| -> Result<f64, SceneError> {
            let v = self.float(el, key)?.unwrap_or(default);
            if v < 0.0 {
                return Err(self.err(el, format!("{key}=\"{v}\" must not be negative")));
            }
            Ok(v)
        };
        let kind = match el.name.as_str() {
            "motor" => ActuatorKind::Motor,
            "position" => ActuatorKind::Position {
                kp: gain("kp", 1.0)?,
                kv: gain("kv", 0.0)?,
            },
            "velocity" => ActuatorKind::Velocity {
                kv: gain("kv", 1.0)?,
            },
            _ => return Err(self.err(el, "unsupported actuator: use motor, position or velocity")),
        };
        let ctrlrange = match (self.floats(el, "ctrlrange", 2)?, el.attr("ctrllimited")) {
            (Some(r), l) if l != Some("false") => {
                if r[0] > r[1] {
                    return Err(self.err(el, "ctrlrange is reversed"));
                }
                Some((r[0], r[1]))
            }
            _ => None,
        };
        let name = el
            .attr("name")
            .map(str::to_string)
            .unwrap_or_else(|| format!("actuator{}", self.actuators.len()));
        if self.actuators.iter().any(|a| a.name == name) {
            return Err(self.err(el, format!("actuator name '{name}' is used twice")));
        }
        self.actuators.push(Actuator {
            name,
            kind,
            joint,
            gear,
            ctrlrange,
        });
        Ok(())
    }

    fn contact(&mut self, el: &Element) -> Result<(), SceneError> {
        for c in &el.children {
            match c.name.as_str() {
                "pair" => {
                    let g1 = c
                        .attr("geom1")
                        .ok_or_else(|| self.err(c, "geom1 is required"))?;
                    let g2 = c
                        .attr("geom2")
                        .ok_or_else(|| self.err(c, "geom2 is required"))?;
                    self.explicit_pairs.push((g1.into(), g2.into(), c.line));
                }
                "exclude" => {
                    let b1 = c
                        .attr("body1")
                        .ok_or_else(|| self.err(c, "body1 is required"))?;
                    let b2 = c
                        .attr("body2")
                        .ok_or_else(|| self.err(c, "body2 is required"))?;
                    self.excludes.push((b1.into(), b2.into(), c.line));
                }
                _ => return Err(self.err(c, "unsupported contact element")),
            }
        }
        Ok(())
    }

    /// An error in an SCM setting, naming its `<numeric>` or `<text>` element.
    fn setting_error(&self, line: usize, name: &str, message: String) -> SceneError {
        let element = if self.text.iter().any(|(n, _, l)| n == name && *l == line) {
            "text"
        } else {
            "numeric"
        };
        SceneError {
            file: self.file.clone(),
            line,
            element: element.into(),
            message: format!("{name}: {message}"),
        }
    }

    fn finish(mut self) -> Result<Scene, SceneError> {
        let mut contact = ContactParams::default();
        let mut spacing = DEFAULT_SPACING;
        let mut step = self.timestep.unwrap_or(DEFAULT_STEP);
        let mut integrator = self.option_integrator.unwrap_or_default();
        let mut tolerance = 1e-6;
        let mut contact_points = 0.0;
        for (name, value, line) in self.numeric.clone() {
            let slot = match name.as_str() {
                "scm_eps1" => &mut contact.eps1,
                "scm_eps2" => &mut contact.eps2,
                "scm_eps3" => &mut contact.eps3,
                "scm_stiffness" => &mut contact.stiffness,
                "scm_dissipation_velocity" => &mut contact.dissipation_velocity,
                "scm_stiction_velocity" => &mut contact.stiction_velocity,
                "scm_friction" => &mut contact.friction,
                "scm_spacing" => &mut spacing,
                "scm_step" => &mut step,
                "scm_tolerance" => &mut tolerance,
                "scm_contact_points" => &mut contact_points,
                _ => return Err(self.setting_error(line, &name, "unknown SCM setting".into())),
            };
            if name == "scm_contact_points"
                && !(value.fract() == 0.0 && (0.0..=64.0).contains(&value))
            {
                return Err(self.setting_error(
                    line,
                    &name,
                    format!("{value} must be a whole number of contact points from 0 to 64"),
                ));
            }
            let ok = if name == "scm_friction" || name == "scm_contact_points" {
                value >= 0.0
            } else {
                value > 0.0
            };
            if !ok {
                return Err(self.setting_error(
                    line,
                    &name,
                    format!(
                        "{value} is out of range (must be {})",
                        if name == "scm_friction" {
                            "non-negative"
                        } else {
                            "positive"
                        }
                    ),
                ));
            }
            *slot = value;
        }
        for (name, value, line) in self.text.clone() {
            match name.as_str() {
                "scm_integrator" => {
                    integrator = Integrator::from_name(&value).ok_or_else(|| {
                        self.setting_error(
                            line,
                            &name,
                            format!(
                                "unknown integrator '{value}' (known: {})",
                                Integrator::ALL.map(|i| i.name()).join(", ")
                            ),
                        )
                    })?
                }
                "scm_dissipation" => {
                    contact.dissipation = Dissipation::from_name(&value).ok_or_else(|| {
                        self.setting_error(
                            line,
                            &name,
                            format!("'{value}' must be 'paper' or 'smooth'"),
                        )
                    })?
                }
                _ => return Err(self.setting_error(line, &name, "unknown SCM setting".into())),
            }
        }
        // Colliders: the union of each body's geoms, minus the faces inside another geom of it.
        let nb = self.bodies.len();
        let mut colliders: Vec<Option<Collider>> = vec![None; nb];
        for (b, slot) in colliders.iter_mut().enumerate() {
            let geoms: Vec<&Geom> = self.geoms.iter().filter(|g| g.body == b).collect();
            let planes: Vec<&&Geom> = geoms.iter().filter(|g| g.shape.is_none()).collect();
            if let Some(p) = planes.first() {
                if geoms.len() > 1 {
                    let line = 0;
                    return Err(SceneError { file: self.file.clone(), line, element: "geom".into(), message: format!("body '{}' has a plane and other geoms: give the plane a body of its own", self.bodies[b].name) });
                }
                *slot = Some(Collider::HalfSpace {
                    point: p.pose.translation.vector,
                    normal: p.pose.rotation * Vector3::z(),
                });
                continue;
            }
            if geoms.is_empty() {
                continue;
            }
            let parts: Vec<(Shape, Isometry3<f64>)> = geoms
                .iter()
                .map(|g| (g.shape.clone().expect("planes handled above"), g.pose))
                .collect();
            let estimate: f64 = parts
                .iter()
                .map(|(shape, _)| estimated_points(shape, spacing))
                .sum();
            if estimate.is_nan() || estimate > MAX_AOPC_POINTS {
                return Err(SceneError {
                    file: self.file.clone(),
                    line: 0,
                    element: "geom".into(),
                    message: format!("body '{}' (geoms {}) would get about {estimate:.3e} AOPC points at scm_spacing = {spacing} m (at most {MAX_AOPC_POINTS:e}): increase scm_spacing or make the geoms smaller", self.bodies[b].name, geoms.iter().map(|g| format!("'{}'", g.name)).collect::<Vec<_>>().join(", ")),
                });
            }
            let aopc = crate::geometry::union::sample_union(&parts, spacing);
            *slot = Some(Collider::Aopc(aopc));
        }
        let tree =
            Tree::new(self.bodies.clone(), self.joints.clone(), self.gravity).map_err(|e| {
                SceneError {
                    file: self.file.clone(),
                    line: 0,
                    element: "body".into(),
                    message: e.to_string(),
                }
            })?;
        let pairs = self.pairs(&tree, &colliders)?;
        let name = Path::new(&self.file)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        let model = Model {
            name,
            tree,
            colliders,
            pairs,
            actuators: std::mem::take(&mut self.actuators),
            contact,
            integrator,
            step,
            tolerance,
            contact_points: contact_points as usize,
        };
        Ok(Scene {
            model,
            geoms: self.geoms,
            warnings: self.warnings,
            meshes: self.meshes,
            meshdir: self.meshdir,
        })
    }

    /// Colliding pairs by MuJoCo's rules: contype/conaffinity bits, no parent–child pairs
    /// (unless the parent is the world), explicit `<pair>` and `<exclude>`; per body pair.
    fn pairs(&self, tree: &Tree, colliders: &[Option<Collider>]) -> Result<Vec<Pair>, SceneError> {
        let nb = tree.bodies.len();
        let body_of = |name: &str, line: usize, what: &str| -> Result<usize, SceneError> {
            tree.bodies
                .iter()
                .position(|b| b.name == name)
                .ok_or_else(|| SceneError {
                    file: self.file.clone(),
                    line,
                    element: what.into(),
                    message: format!("no body named '{name}'"),
                })
        };
        let mut excluded = Vec::new();
        for (b1, b2, line) in &self.excludes {
            let (x, y) = (
                body_of(b1, *line, "exclude")?,
                body_of(b2, *line, "exclude")?,
            );
            excluded.push((x.min(y), x.max(y)));
        }
        let mut explicit = Vec::new();
        for (g1, g2, line) in &self.explicit_pairs {
            let find = |g: &str| {
                self.geoms
                    .iter()
                    .find(|x| x.name == g)
                    .map(|x| x.body)
                    .ok_or_else(|| SceneError {
                        file: self.file.clone(),
                        line: *line,
                        element: "pair".into(),
                        message: format!("no geom named '{g}'"),
                    })
            };
            let (x, y) = (find(g1)?, find(g2)?);
            if x == y {
                return Err(SceneError {
                    file: self.file.clone(),
                    line: *line,
                    element: "pair".into(),
                    message: "both geoms belong to the same body".into(),
                });
            }
            explicit.push((x.min(y), x.max(y)));
        }
        let mut pairs = Vec::new();
        for a in 0..nb {
            for b in a + 1..nb {
                let (Some(ca), Some(cb)) = (&colliders[a], &colliders[b]) else {
                    continue;
                };
                if matches!(
                    (ca, cb),
                    (Collider::HalfSpace { .. }, Collider::HalfSpace { .. })
                ) {
                    continue;
                }
                if !tree.body_moves(a) && !tree.body_moves(b) {
                    continue;
                }
                let by_rules = {
                    let compatible = self.geoms.iter().filter(|g| g.body == a).any(|ga| {
                        self.geoms.iter().filter(|g| g.body == b).any(|gb| {
                            (ga.contype & gb.conaffinity) != 0 || (gb.contype & ga.conaffinity) != 0
                        })
                    });
                    let parent_child = (tree.bodies[b].parent == Some(a) && a != 0)
                        || (tree.bodies[a].parent == Some(b) && b != 0);
                    compatible && !parent_child && !excluded.contains(&(a, b))
                };
                if by_rules || explicit.contains(&(a, b)) {
                    pairs.push(Pair { a, b });
                }
            }
        }
        Ok(pairs)
    }
}

/// Inertia of a solid of mass `mass` with unit-density properties `mp`, posed at `pose`: its
/// centre of mass and rotational inertia in the body frame.
fn geom_inertia(mp: &crate::geometry::MassProperties, mass: f64, pose: &Isometry3<f64>) -> Inertia {
    let r = pose.rotation.to_rotation_matrix().into_inner();
    let per = if mp.volume > 0.0 {
        mass / mp.volume
    } else {
        0.0
    };
    Inertia {
        mass,
        com: (pose * nalgebra::Point3::from(mp.com)).coords,
        rot: r * mp.inertia * r.transpose() * per,
    }
}

/// Where a mesh file is: absolute as given, else relative to the scene file's folder joined
/// with `meshdir` (itself relative to the scene's folder unless absolute), as MuJoCo does.
///
/// Inside an unpacked FMU (the scene is `resources/scene.xml`), a mesh that is not found there
/// is looked up where `scm pack` puts it: `resources/` + [`packed_mesh_name`].
pub fn mesh_path(scene: &Path, meshdir: Option<&str>, file: &str) -> PathBuf {
    let f = Path::new(file);
    if f.is_absolute() {
        return f.to_path_buf();
    }
    let mut dir = scene_dir(scene);
    if let Some(d) = meshdir {
        dir = dir.join(d);
    }
    let path = dir.join(f);
    let in_fmu = scene
        .file_name()
        .is_some_and(|n| n == crate::sim::SCENE_FILE)
        && scene_dir(scene)
            .file_name()
            .is_some_and(|n| n == "resources");
    if !path.exists() && in_fmu {
        if let Ok(packed) = packed_mesh_name(file) {
            let p = scene_dir(scene).join(packed);
            if p.exists() {
                return p;
            }
        }
    }
    path
}

/// The name under an FMU's `resources/` of a mesh whose `file` attribute is `file`:
/// `meshes/<file>`, with `.` and `..` resolved (a path that leaves the mesh folder, or an
/// absolute one, cannot be packed).
pub fn packed_mesh_name(file: &str) -> Result<String, String> {
    if Path::new(file).is_absolute() {
        return Err("an absolute path cannot be packed: give the file relative to meshdir".into());
    }
    let mut parts: Vec<&str> = Vec::new();
    for c in file.split(['/', '\\']) {
        match c {
            "" | "." => {}
            ".." => {
                parts
                    .pop()
                    .ok_or("the path leaves the mesh folder: give the file relative to meshdir")?;
            }
            c => parts.push(c),
        }
    }
    if parts.is_empty() {
        return Err("empty file name".into());
    }
    Ok(format!("meshes/{}", parts.join("/")))
}

/// The folder a scene's relative paths start from.
pub fn scene_dir(path: &Path) -> PathBuf {
    path.parent().map(Path::to_path_buf).unwrap_or_default()
}
