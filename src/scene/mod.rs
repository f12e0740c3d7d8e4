//! Scene loader: a subset of MuJoCo's MJCF (docs/mjcf.md), so the same file runs in MuJoCo and here.
//!
//! SCM settings come as `<custom><numeric name="scm_..." data="..."/>` (numbers) or
//! `<custom><text name="scm_..." data="..."/>` (names), which MuJoCo ignores. Visual-only
//! elements are skipped; a physics element or attribute we do not model is an error naming the
//! file, the line and the element.

pub mod canonical;
pub mod defaults;
pub mod filter;
pub mod include;
pub mod json;
pub mod xml;

use crate::collision::Collider;
use crate::contact::{ContactParams, Dissipation};
use crate::dynamics::fluid::{Fluid, FluidBody};
use crate::dynamics::spatial::Inertia;
use crate::dynamics::{Body, Joint, JointKind, Tree};
use crate::geometry::{Shape, TriMesh};
use crate::integrate::Integrator;
use crate::model::{Actuator, ActuatorKind, Model, Pair};
use canonical::Angles;
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
    /// Elements and attributes accepted and unused by SCM: MuJoCo's renderer and solver
    /// settings (for `scm check` and the FMU documentation).
    pub unused: Vec<String>,
    /// Mesh assets the geoms use: name, the `file` attribute as written, and the resolved path.
    pub meshes: Vec<MeshAsset>,
    /// The compiler's mesh folder as written (`meshdir`, else `assetdir`), relative to the
    /// scene file.
    pub meshdir: Option<String>,
    /// Files read through `<include>`, in order.
    pub includes: Vec<include::IncludedFile>,
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
    /// Sliding friction coefficient (the first of MuJoCo's `friction`, default 1).
    pub friction: f64,
    /// MuJoCo's contact dimensionality (`condim`, default 3; 1 is frictionless).
    pub condim: u32,
    /// The file that declares the geom.
    pub file: String,
    /// Its line there.
    pub line: usize,
}

/// Default spacing between AOPC points when the scene gives no `scm_spacing` (m).
pub const DEFAULT_SPACING: f64 = 0.01;
/// Most AOPC points one body may get, estimated from its geoms' surface area before sampling
/// (a point per `scm_spacing`² of surface, at least three per mesh triangle). A body at the
/// limit takes about 650 MB (about 320 bytes per point with its BVH, see docs/performance.md)
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

/// Name of the scene file inside an FMU's `resources/` folder.
pub const SCENE_FILE: &str = "scene.xml";

/// Default internal step when neither `scm_step` nor `<option timestep>` is given (s).
pub const DEFAULT_STEP: f64 = 0.002;

/// Loads a scene file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    load_str(&read_text(path)?, path)
}

/// The text of a scene file; an unreadable file is a [`SceneError`] naming it.
pub fn read_text(path: &Path) -> Result<String, SceneError> {
    std::fs::read_to_string(path).map_err(|e| SceneError {
        file: path.display().to_string(),
        line: 0,
        element: "mujoco".into(),
        message: format!("cannot read the scene: {e}"),
    })
}

/// A scene compiled as MuJoCo's compiler would (bodies, inertias, joints, geoms, actuators),
/// before SCM builds its colliders: what the differential tests compare with MuJoCo's
/// `MjModel`, and what `scm compile` prints.
#[derive(Clone, Debug)]
pub struct Compiled {
    /// Bodies and joints.
    pub tree: Tree,
    /// Geoms, in file order.
    pub geoms: Vec<Geom>,
    /// Actuators.
    pub actuators: Vec<Actuator>,
    /// `<option timestep>` (s).
    pub timestep: f64,
    /// `<option integrator>` as SCM maps it.
    pub integrator: Integrator,
    /// Each joint's limits (m or rad), if limited.
    pub limits: Vec<Option<(f64, f64)>>,
    /// What SCM refuses to simulate, with file and line.
    pub refused: Vec<SceneError>,
    /// Accepted and unused by SCM.
    pub unused: Vec<String>,
    /// Accepted but modelled differently from MuJoCo.
    pub warnings: Vec<String>,
}

/// Compiles a scene file without building colliders and without refusing: see [`Compiled`].
pub fn compile(path: &Path) -> Result<Compiled, SceneError> {
    let text = read_text(path)?;
    let (b, _) = read(&text, path)?;
    b.compiled()
}

/// Parses, expands includes, reads compiler and defaults, canonicalizes and reads the tree.
fn read(text: &str, path: &Path) -> Result<(Builder, Vec<include::IncludedFile>), SceneError> {
    let file = path.display().to_string();
    let mut root = xml::parse(text, &file).map_err(|e| SceneError {
        file: file.clone(),
        line: e.line,
        element: "xml".into(),
        message: e.message,
    })?;
    let mut b = Builder::new(file);
    if root.name != "mujoco" {
        return Err(b.err(&root, "the root element must be <mujoco>"));
    }
    let includes = include::expand(&mut root, path)?;
    let mut defaults = defaults::Defaults::default();
    for el in &root.children {
        match el.name.as_str() {
            "compiler" => b.compiler(el)?,
            "default" => defaults.read(el)?,
            _ => {}
        }
    }
    canonical::canonicalize(&mut root, &defaults, &b.angles)?;
    b.scene(&root)?;
    Ok((b, includes))
}

/// Loads a scene from text; `path` names it in errors and anchors relative paths (meshes,
/// includes).
///
/// The pipeline: parse, expand `<include>`s, read the compiler settings and default classes,
/// bring the tree into canonical form ([`canonical`]), then build the model from it.
pub fn load_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let (b, includes) = read(text, path)?;
    let mut scene = b.finish()?;
    scene.includes = includes;
    Ok(scene)
}

/// How body inertias come from geoms (`<compiler inertiafromgeom>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum InertiaFromGeom {
    /// From the geoms unless the body has an `<inertial>` (MuJoCo's default).
    Auto,
    /// Always from the geoms; `<inertial>` is overridden.
    Always,
    /// Never: a body without `<inertial>` has no mass.
    Never,
}

/// `<compiler>` settings that shape the model.
#[derive(Clone, Copy, Debug)]
struct CompilerSettings {
    /// Joint and control ranges make a joint or control limited when `limited` is not given.
    autolimits: bool,
    inertia_from_geom: InertiaFromGeom,
    /// Geom groups whose geoms add mass.
    inertia_groups: (i64, i64),
    /// Scale every mass and inertia so the bodies weigh this much in total (kg; off if <= 0).
    total_mass: f64,
    /// Least mass of a body (kg).
    bound_mass: f64,
    /// Least principal moment of inertia of a body (kg m²).
    bound_inertia: f64,
}

impl Default for CompilerSettings {
    fn default() -> Self {
        CompilerSettings {
            autolimits: true,
            inertia_from_geom: InertiaFromGeom::Auto,
            inertia_groups: (0, 5),
            total_mass: -1.0,
            bound_mass: 0.0,
            bound_inertia: 0.0,
        }
    }
}

/// `<option><flag>` switches that change the physics (all on by default, as in MuJoCo).
#[derive(Clone, Copy, Debug)]
struct Flags {
    gravity: bool,
    contact: bool,
    limit: bool,
    equality: bool,
    frictionloss: bool,
    spring: bool,
    damper: bool,
    actuation: bool,
    filterparent: bool,
    clampctrl: bool,
    eulerdamp: bool,
}

impl Default for Flags {
    fn default() -> Self {
        Flags {
            gravity: true,
            contact: true,
            limit: true,
            equality: true,
            frictionloss: true,
            spring: true,
            damper: true,
            actuation: true,
            filterparent: true,
            clampctrl: true,
            eulerdamp: true,
        }
    }
}

/// Attributes that only configure MuJoCo's renderer or constraint solver (or carry user data):
/// accepted anywhere and listed as unused by SCM, with why.
const UNUSED_ATTRIBUTES: &[(&str, &str)] = &[
    ("rgba", "renderer"),
    ("material", "renderer"),
    ("texture", "renderer"),
    ("group", "renderer groups"),
    ("user", "user data"),
    ("margin", "MuJoCo's contact solver"),
    ("gap", "MuJoCo's contact solver"),
    (
        "solref",
        "MuJoCo's constraint solver; SCM's contact comes from its scm_ settings",
    ),
    (
        "solimp",
        "MuJoCo's constraint solver; SCM's contact comes from its scm_ settings",
    ),
    ("solmix", "MuJoCo's contact solver"),
    ("priority", "MuJoCo's contact solver"),
    ("solimplimit", "MuJoCo's constraint solver"),
    ("solreffriction", "MuJoCo's constraint solver"),
    ("solimpfriction", "MuJoCo's constraint solver"),
    ("iterations", "MuJoCo's constraint solver"),
    ("ls_iterations", "MuJoCo's constraint solver"),
    ("noslip_iterations", "MuJoCo's constraint solver"),
    ("ccd_iterations", "MuJoCo's collision detection"),
    ("sdf_iterations", "MuJoCo's collision detection"),
    ("sdf_initpoints", "MuJoCo's collision detection"),
    ("tolerance", "MuJoCo's constraint solver"),
    ("ls_tolerance", "MuJoCo's constraint solver"),
    ("noslip_tolerance", "MuJoCo's constraint solver"),
    ("ccd_tolerance", "MuJoCo's collision detection"),
    ("impratio", "MuJoCo's friction cone"),
    ("cone", "MuJoCo's friction cone"),
    ("jacobian", "MuJoCo's constraint solver"),
    ("solver", "MuJoCo's constraint solver"),
    ("apirate", "MuJoCo's remote API"),
    ("o_margin", "MuJoCo's contact override"),
    ("o_solref", "MuJoCo's contact override"),
    ("o_solimp", "MuJoCo's contact override"),
    ("o_friction", "MuJoCo's contact override"),
    ("actuatorgroupdisable", "MuJoCo's actuator groups"),
    ("texturedir", "renderer"),
    ("inertiagrouprange", "read"),
    ("align", "renderer"),
    ("mode", "camera tracking"),
    ("target", "camera tracking"),
];

/// What to do instead, for an attribute SCM refuses, where there is a clear answer.
fn advice(element: &str, attr: &str) -> &'static str {
    match (element, attr) {
        (_, "class") | (_, "childclass") => ": defaults should have been applied (report this)",
        ("geom", "fluidshape") | ("geom", "fluidcoef") => {
            ": fluid forces are not supported; remove them"
        }
        ("joint", "actuatorfrcrange") | ("joint", "actuatorfrclimited") => {
            ": limit the actuators' forcerange instead"
        }
        ("joint", "actuatorgravcomp") => {
            ": gravity compensation through the actuators is not modelled; remove it (the bodies' gravcomp then acts as a passive force, MuJoCo's default)"
        }
        _ => "",
    }
}

const NO_INERTIA: Inertia = Inertia {
    mass: 0.0,
    com: Vector3::new(0.0, 0.0, 0.0),
    rot: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
};

struct Builder {
    file: String,
    angles: Angles,
    /// `<compiler>` settings that shape the model.
    settings: CompilerSettings,
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
    /// `<pair geom1 geom2 friction>`: the names, the sliding friction if given, the line.
    explicit_pairs: Vec<(String, String, Option<f64>, usize)>,
    excludes: Vec<(String, String, usize)>,
    /// Whether each body's inertia came from `<inertial>`.
    explicit_inertia: Vec<bool>,
    /// Each body's inertia from its geoms (used as `inertiafromgeom` says).
    geom_inertia: Vec<Inertia>,
    warnings: Vec<String>,
    /// Elements and attributes accepted and unused by SCM (file:line: what, why).
    unused: Vec<String>,
    flags: Flags,
    /// `<keyframe><key>` elements, in order; `scm_keyframe` picks the initial state.
    keys: Vec<Element>,
    /// Refusals found while reading (reported after the whole file is read).
    refused: Vec<SceneError>,
    /// The `<option>` that asks for fluid forces, if any.
    fluid: Option<Element>,
    /// `<option density viscosity>`.
    medium: (f64, f64),
    /// `<option wind>`.
    wind: Vector3<f64>,
    /// Orientation of each `<inertial diaginertia>` (its principal axes).
    inertial_axes: std::collections::BTreeMap<usize, UnitQuaternion<f64>>,
    /// Orientation of each geom that gives its body mass, per body.
    mass_geom_frames: std::collections::BTreeMap<usize, Vec<UnitQuaternion<f64>>>,
    /// Whether each joint is limited (its `range` and line, in SI units) by `limited` or
    /// `autolimits`.
    limits: Vec<Option<(f64, f64, Element)>>,
    /// Each joint's `solreflimit` (MuJoCo's default `0.02 1`).
    solreflimit: Vec<[f64; 2]>,
}

/// An error at an element: its file, line and name.
fn element_error(el: &Element, message: impl Into<String>) -> SceneError {
    SceneError {
        file: el.file.to_string(),
        line: el.line,
        element: el.name.clone(),
        message: message.into(),
    }
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
            angles: Angles::default(),
            settings: CompilerSettings::default(),
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
                gravcomp: 0.0,
            }],
            joints: vec![],
            geoms: vec![],
            actuators: vec![],
            gravity: Vector3::new(0.0, 0.0, -9.81),
            timestep: None,
            option_integrator: None,
            numeric: vec![],
            text: vec![],
            explicit_pairs: vec![],
            excludes: vec![],
            explicit_inertia: vec![false],
            geom_inertia: vec![NO_INERTIA],
            warnings: vec![],
            unused: vec![],
            flags: Flags::default(),
            fluid: None,
            medium: (0.0, 0.0),
            wind: Vector3::zeros(),
            inertial_axes: Default::default(),
            mass_geom_frames: Default::default(),
            keys: vec![],
            refused: vec![],
            limits: vec![],
            solreflimit: vec![],
        }
    }

    fn err(&self, el: &Element, message: impl Into<String>) -> SceneError {
        element_error(el, message)
    }

    /// Rejects attributes outside `allowed`; those in [`UNUSED_ATTRIBUTES`] are accepted and
    /// noted as unused by SCM.
    fn check_attrs(&mut self, el: &Element, allowed: &[&str]) -> Result<(), SceneError> {
        let mut unused = Vec::new();
        for (k, _) in &el.attrs {
            if allowed.contains(&k.as_str()) {
                continue;
            }
            match UNUSED_ATTRIBUTES.iter().find(|(a, _)| a == k) {
                Some((a, why)) => unused.push(format!("{a} ({why})")),
                None => {
                    return Err(self.err(
                        el,
                        format!(
                            "attribute '{k}' is not supported by SCM{}",
                            advice(&el.name, k)
                        ),
                    ))
                }
            }
        }
        if !unused.is_empty() {
            self.unused(el, unused.join(", "));
        }
        Ok(())
    }

    /// Notes that `what` of `el` is accepted and unused by SCM.
    fn unused(&mut self, el: &Element, what: impl Into<String>) {
        self.unused.push(format!(
            "{}:{}: <{}> {}",
            el.file,
            el.line,
            el.name,
            what.into()
        ));
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

    fn pose(&self, el: &Element) -> Result<Isometry3<f64>, SceneError> {
        canonical::pose(el, &self.angles)
    }

    fn scene(&mut self, root: &Element) -> Result<(), SceneError> {
        self.check_attrs(root, &["model"])?;
        // Settings first: they apply wherever they appear in the file (the compiler and the
        // defaults were read before the tree was made canonical).
        for el in &root.children {
            match el.name.as_str() {
                "option" => self.option(el)?,
                "custom" => self.custom(el)?,
                _ => {}
            }
        }
        // Assets next (they may come after the bodies that use them).
        for el in root.children.iter().filter(|e| e.name == "asset") {
            for a in &el.children {
                match a.name.as_str() {
                    "texture" | "material" | "skin" | "model" => self.unused(a, "renderer asset"),
                    "mesh" => self.mesh_asset(a)?,
                    "hfield" => {
                        return Err(self.err(
                            a,
                            "height fields are not supported by SCM: use a mesh or primitive geoms",
                        ))
                    }
                    _ => return Err(self.err(a, "unknown asset")),
                }
            }
        }
        for el in &root.children {
            match el.name.as_str() {
                "compiler" | "option" | "default" | "custom" | "asset" => {}
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
                "tendon" => {
                    for t in &el.children {
                        self.tendon(t)?;
                    }
                }
                "equality" => {
                    if let Some(e) = el.children.first() {
                        if self.flags.equality {
                            return Err(self.err(e, "equality constraints are not supported by SCM yet: remove them, or switch them off with <option><flag equality=\"disable\"/></option>"));
                        }
                        self.unused(
                            el,
                            "equality constraints switched off by <flag equality=\"disable\">",
                        );
                    }
                }
                "visual" | "statistic" | "size" | "extension" => {
                    self.unused(el, "renderer and memory settings")
                }
                "sensor" => self.unused(el, "sensors (SCM's outputs are its FMU variables)"),
                "keyframe" => {
                    for k in &el.children {
                        if k.name != "key" {
                            return Err(self.err(k, "a <keyframe> holds <key> elements"));
                        }
                        self.check_attrs(
                            k,
                            &[
                                "name", "time", "qpos", "qvel", "act", "ctrl", "mpos", "mquat",
                            ],
                        )?;
                        self.keys.push(k.clone());
                    }
                }
                _ => return Err(self.err(el, "unsupported element")),
            }
        }
        Ok(())
    }

    /// `<compiler>`: read before the tree is made canonical (the angle unit and Euler
    /// sequence decide how orientations read).
    fn compiler(&mut self, el: &Element) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "angle",
                "eulerseq",
                "coordinate",
                "meshdir",
                "assetdir",
                "texturedir",
                "autolimits",
                "inertiafromgeom",
                "inertiagrouprange",
                "settotalmass",
                "boundmass",
                "boundinertia",
                "strippath",
                "discardvisual",
                "fusestatic",
                "usethread",
                "fitaabb",
                "saveinertial",
                "alignfree",
            ],
        )?;
        match el.attr("angle") {
            None => {}
            Some("degree") => self.angles.degrees = true,
            Some("radian") => self.angles.degrees = false,
            Some(a) => {
                return Err(self.err(el, format!("angle=\"{a}\": expected degree or radian")))
            }
        }
        if let Some(seq) = el.attr("eulerseq") {
            self.angles.eulerseq = Angles::parse_eulerseq(seq).ok_or_else(|| {
                self.err(
                    el,
                    format!("eulerseq=\"{seq}\": expected three of x y z X Y Z"),
                )
            })?;
        }
        match el.attr("coordinate") {
            None | Some("local") => {}
            Some(c) => return Err(self.err(el, format!("coordinate=\"{c}\": MuJoCo only reads local coordinates (since 2.3.3): give every pose relative to its parent"))),
        }
        if let Some(d) = el.attr("meshdir").or(el.attr("assetdir")) {
            self.meshdir = Some(d.to_string());
        }
        let flag = |key: &str| -> Result<Option<bool>, SceneError> {
            match el.attr(key) {
                None => Ok(None),
                Some("true") => Ok(Some(true)),
                Some("false") => Ok(Some(false)),
                Some(v) => Err(element_error(
                    el,
                    format!("{key}=\"{v}\": expected true or false"),
                )),
            }
        };
        if let Some(a) = flag("autolimits")? {
            self.settings.autolimits = a;
        }
        for (key, why) in [
            (
                "discardvisual",
                "SCM keeps every geom; visual-only geoms never collide here either",
            ),
            ("fusestatic", "fusing static bodies changes no motion"),
            ("strippath", "mesh paths are read as written"),
            ("usethread", "compiler threading"),
            ("saveinertial", "output only"),
        ] {
            if el.attr(key).is_some() {
                self.unused(el, format!("{key} ({why})"));
            }
        }
        if flag("alignfree")? == Some(true) {
            return Err(self.err(el, "alignfree=\"true\" moves free bodies' frames to their inertia frames: not supported by SCM, leave it false"));
        }
        if el.attr("fitaabb").is_some() {
            return Err(self.err(el, "fitaabb applies to mesh-fitted primitives, which SCM does not support: give primitive geoms their sizes"));
        }
        match el.attr("inertiafromgeom") {
            None => {}
            Some("auto") => self.settings.inertia_from_geom = InertiaFromGeom::Auto,
            Some("true") => self.settings.inertia_from_geom = InertiaFromGeom::Always,
            Some("false") => self.settings.inertia_from_geom = InertiaFromGeom::Never,
            Some(v) => {
                return Err(self.err(
                    el,
                    format!("inertiafromgeom=\"{v}\": expected true, false or auto"),
                ))
            }
        }
        if let Some(r) = el.attr("inertiagrouprange") {
            let v: Option<Vec<i64>> = r.split_whitespace().map(|t| t.parse().ok()).collect();
            match v.as_deref() {
                Some([lo, hi]) => self.settings.inertia_groups = (*lo, *hi),
                _ => {
                    return Err(self.err(
                        el,
                        format!("inertiagrouprange=\"{r}\": expected two integers"),
                    ))
                }
            }
        }
        for (key, slot) in [
            ("settotalmass", &mut self.settings.total_mass),
            ("boundmass", &mut self.settings.bound_mass),
            ("boundinertia", &mut self.settings.bound_inertia),
        ] {
            if let Some(s) = el.attr(key) {
                match parse_floats(s).as_deref() {
                    Some([v]) => *slot = *v,
                    _ => {
                        return Err(SceneError {
                            file: el.file.to_string(),
                            line: el.line,
                            element: el.name.clone(),
                            message: format!("{key}=\"{s}\": expected one finite number"),
                        })
                    }
                }
            }
        }
        Ok(())
    }

    fn option(&mut self, el: &Element) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "timestep",
                "gravity",
                "integrator",
                "density",
                "viscosity",
                "wind",
                "magnetic",
            ],
        )?;
        if let Some(t) = self.float(el, "timestep")? {
            if t <= 0.0 {
                return Err(self.err(el, format!("timestep=\"{t}\" must be positive")));
            }
            self.timestep = Some(t);
        }
        if let Some(g) = self.vec3(el, "gravity")? {
            self.gravity = g;
        }
        for (k, key) in ["density", "viscosity"].into_iter().enumerate() {
            if let Some(v) = self.float(el, key)? {
                if v < 0.0 {
                    return Err(self.err(el, format!("{key}=\"{v}\" must not be negative")));
                }
                if k == 0 {
                    self.medium.0 = v;
                } else {
                    self.medium.1 = v;
                }
            }
        }
        if self.medium != (0.0, 0.0) {
            self.fluid = Some(el.clone());
        }
        if let Some(w) = self.vec3(el, "wind")? {
            self.wind = w;
        }
        if el.attr("magnetic").is_some() {
            self.unused(el, "magnetic (the magnetometer sensor's field)");
        }
        if el.attr("wind").is_some() && self.fluid.is_none() {
            self.unused(
                el,
                "wind (acts only through fluid forces, off here: density and viscosity are 0)",
            );
        }
        match el.attr("integrator") {
            None => {}
            // MuJoCo's "Euler" is semi-implicit in velocity, with joint damping implicit
            // (unless <flag eulerdamp="disable">, applied in `apply_flags`).
            Some("Euler") => self.option_integrator = Some(Integrator::DampedEuler),
            Some("RK4") => self.option_integrator = Some(Integrator::Rk4),
            // MuJoCo's implicit integrators are implicit in the velocity-dependent forces; SCM's
            // implicit Euler covers that and the stiff contact too.
            Some("implicit") | Some("implicitfast") => {
                self.option_integrator = Some(Integrator::ImplicitEuler)
            }
            Some("discrete") => return Err(self.err(el, "integrator=\"discrete\" (MuJoCo 4's discrete-time integrator) is not supported by SCM: use Euler, RK4 or implicitfast, or choose one of SCM's with <custom><text name=\"scm_integrator\">")),
            Some(i) => {
                return Err(self.err(el, format!("integrator=\"{i}\" is not a MuJoCo integrator")))
            }
        };
        for f in &el.children {
            if f.name != "flag" {
                return Err(self.err(f, "an <option> holds only <flag>"));
            }
            self.flag(f)?;
        }
        Ok(())
    }

    /// `<option><flag>`: the switches that turn a force on or off are honoured; the rest
    /// configure MuJoCo's solver and are noted as unused.
    fn flag(&mut self, el: &Element) -> Result<(), SceneError> {
        for (k, v) in &el.attrs {
            let on = match v.as_str() {
                "enable" => true,
                "disable" => false,
                _ => return Err(self.err(el, format!("{k}=\"{v}\": expected enable or disable"))),
            };
            let f = &mut self.flags;
            match k.as_str() {
                "gravity" => f.gravity = on,
                "contact" => f.contact = on,
                "limit" => f.limit = on,
                "equality" => f.equality = on,
                "frictionloss" => f.frictionloss = on,
                "spring" => f.spring = on,
                "damper" => f.damper = on,
                "actuation" => f.actuation = on,
                "filterparent" => f.filterparent = on,
                "clampctrl" => f.clampctrl = on,
                "eulerdamp" => f.eulerdamp = on,
                "constraint" => {
                    // Every constraint: contacts, limits, equalities, friction loss.
                    f.contact &= on;
                    f.limit &= on;
                    f.equality &= on;
                    f.frictionloss &= on;
                }
                "passive" => return Err(self.err(el, "flag passive was MuJoCo 2's; MuJoCo 3 and 4 refuse it: use spring=\"disable\" damper=\"disable\"")),
                "warmstart" | "energy" | "sensor" | "midphase" | "island" | "nativeccd"
                | "multiccd" | "refsafe" | "fwdinv" | "invdiscrete" | "autoreset" | "override"
                | "sleep" | "diagexact" | "speculative" | "ipc" => {
                    let why = format!("flag {k} (MuJoCo's solver and pipeline)");
                    self.unused(el, why);
                }
                _ => return Err(self.err(el, format!("'{k}' is not a MuJoCo flag"))),
            }
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
        self.check_attrs(el, &["name", "pos", "quat", "mocap", "gravcomp"])?;
        let gravcomp = self.float(el, "gravcomp")?.unwrap_or(0.0);
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
            gravcomp,
        });
        self.explicit_inertia.push(false);
        self.geom_inertia.push(NO_INERTIA);
        for child in &el.children {
            self.body_child(child, index)?;
        }
        Ok(())
    }

    fn joint(&mut self, el: &Element, body: usize, free: bool) -> Result<(), SceneError> {
        if free {
            self.check_attrs(el, &["name", "align"])?;
        } else {
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
                    "springdamper",
                    "solreflimit",
                ],
            )?;
        }
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
        if self
            .floats(el, "springdamper", 2)?
            .is_some_and(|v| v != [0.0, 0.0])
        {
            return Err(self.err(
                el,
                "springdamper is not supported by SCM: give stiffness and damping",
            ));
        }
        // Hinge angles are read in the compiler's unit; ball ranges too.
        let angular = |v: f64| {
            if kind == JointKind::Hinge || kind == JointKind::Ball {
                self.angles.radians(v)
            } else {
                v
            }
        };
        let (mut reference, mut springref) = (0.0, 0.0);
        for (key, slot) in [("ref", &mut reference), ("springref", &mut springref)] {
            if let Some(v) = self.float(el, key)? {
                if v != 0.0 && !matches!(kind, JointKind::Slide | JointKind::Hinge) {
                    return Err(
                        self.err(el, format!("{key} applies to slide and hinge joints only"))
                    );
                }
                *slot = angular(v);
            }
        }
        let range = self.floats(el, "range", 2)?;
        let limited = match (el.attr("limited"), range.is_some()) {
            (Some("true"), _) => true,
            (Some("false"), _) => false,
            (None | Some("auto"), has_range) => {
                if has_range && !self.settings.autolimits && el.attr("limited").is_some() {
                    return Err(
                        self.err(el, "limited=\"auto\" needs <compiler autolimits=\"true\">")
                    );
                }
                has_range && self.settings.autolimits
            }
            (Some(v), _) => {
                return Err(self.err(el, format!("limited=\"{v}\": expected true, false or auto")))
            }
        };
        let limit = match (limited, &range) {
            (false, _) => None,
            (true, None) => return Err(self.err(el, "limited joint without range")),
            (true, Some(r)) => {
                if r[0] >= r[1] && kind != JointKind::Ball {
                    return Err(self.err(el, "range: the lower limit must be below the upper one"));
                }
                if kind == JointKind::Free {
                    return Err(self.err(el, "a free joint cannot be limited"));
                }
                Some((angular(r[0]), angular(r[1]), el.clone()))
            }
        };
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
            // A free joint without a name is named after its body, however it is written.
            None if kind == JointKind::Free => self.bodies[body].name.clone(),
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
            reference,
            springref,
            limit: None,
            qadr: 0,
            dadr: 0,
            body,
        };
        self.joints.push(joint);
        self.limits.push(limit);
        let solref = self
            .floats(el, "solreflimit", 2)?
            .unwrap_or(vec![0.02, 1.0]);
        self.solreflimit.push([solref[0], solref[1]]);
        self.bodies[body].joints.push(index);
        Ok(())
    }

    fn geom(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
        self.check_attrs(
            el,
            &[
                "name",
                "type",
                "size",
                "pos",
                "quat",
                "fromto",
                "group",
                "shellinertia",
                "mass",
                "density",
                "friction",
                "contype",
                "conaffinity",
                "condim",
                "mesh",
            ],
        )?;
        if el.attr("shellinertia").is_some_and(|v| v != "false") {
            return Err(self.err(
                el,
                "shellinertia is not supported by SCM: give the body an <inertial>",
            ));
        }
        if matches!(el.attr("condim"), Some("4") | Some("6")) {
            self.unused(
                el,
                "condim 4 and 6 (MuJoCo's torsional and rolling friction)",
            );
        }
        let friction = match el.attr("friction").map(parse_floats) {
            None => 1.0,
            Some(Some(v)) if (1..=3).contains(&v.len()) && v[0] >= 0.0 => {
                if v[1..].iter().any(|&x| x != 0.0) {
                    self.unused(el, "friction's torsional and rolling coefficients (SCM models sliding friction)");
                }
                v[0]
            }
            Some(_) => {
                return Err(self.err(
                    el,
                    format!(
                        "friction=\"{}\": expected 1 to 3 non-negative numbers",
                        el.attr("friction").unwrap_or("")
                    ),
                ))
            }
        };
        let condim: u32 = match el.attr("condim") {
            None => 3,
            Some(c) => c
                .trim()
                .parse()
                .ok()
                .filter(|c| [1, 3, 4, 6].contains(c))
                .ok_or_else(|| self.err(el, format!("condim=\"{c}\": expected 1, 3, 4 or 6")))?,
        };
        let size = el.attr("size").and_then(parse_floats).unwrap_or_default();
        let kind = el.attr("type").unwrap_or("sphere");
        let fromto = self.floats(el, "fromto", 6)?;
        // With fromto, the geom runs from one point to the other along its z axis.
        let from_to = match fromto {
            Some(_) if !matches!(kind, "capsule" | "cylinder" | "box" | "ellipsoid") => {
                return Err(self.err(el, format!("fromto does not apply to a {kind}")))
            }
            Some(f) => {
                let (a, b) = (
                    Vector3::new(f[0], f[1], f[2]),
                    Vector3::new(f[3], f[4], f[5]),
                );
                let axis = b - a;
                if axis.norm() < 1e-12 {
                    return Err(self.err(el, "fromto: the two points coincide"));
                }
                // MuJoCo points the geom's z axis from the second point to the first.
                Some((
                    Isometry3::from_parts(
                        Translation3::from((a + b) * 0.5),
                        canonical::z_to(&(a - b)),
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
            let group: i64 = match el.attr("group") {
                None => 0,
                Some(g) => g
                    .trim()
                    .parse()
                    .map_err(|_| self.err(el, format!("group=\"{g}\" must be an integer")))?,
            };
            let (lo, hi) = self.settings.inertia_groups;
            if body != 0 && (lo..=hi).contains(&group) {
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
                self.geom_inertia[body] = self.geom_inertia[body].add(&gi);
                self.mass_geom_frames
                    .entry(body)
                    .or_default()
                    .push(pose.rotation);
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
            friction,
            condim,
            file: el.file.to_string(),
            line: el.line,
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
        // SCM computes the exact mass properties of the closed mesh, which is MuJoCo's
        // inertia="exact"; its default ("legacy") and "convex" differ for non-convex meshes.
        match el.attr("inertia") {
            Some("exact") => {}
            Some("shell") => {
                return Err(self.err(el, "inertia=\"shell\" is not supported by SCM: use exact (a solid mesh), or give the body an <inertial>"))
            }
            Some("legacy" | "convex") => {}
            Some(v) => {
                return Err(self.err(el, format!("inertia=\"{v}\": expected exact, convex, legacy or shell")))
            }
            None => {}
        }
        if el.attr("inertia") != Some("exact") {
            self.warnings.push(format!(
                "{}:{}: mesh inertia=\"{}\": SCM computes the exact inertia of the closed mesh; MuJoCo's can differ for a non-convex mesh (write inertia=\"exact\" for the same masses in both)",
                el.file, el.line, el.attr("inertia").unwrap_or("legacy")
            ));
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
        self.check_attrs(el, &["pos", "quat", "mass", "diaginertia", "fullinertia"])?;
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
            (Some(d), None) => {
                self.inertial_axes.insert(body, pose.rotation);
                Matrix3::from_diagonal(&d)
            }
            (None, Some(f)) => Matrix3::new(f[0], f[3], f[4], f[3], f[1], f[5], f[4], f[5], f[2]),
            _ => return Err(self.err(el, "give exactly one of diaginertia and fullinertia")),
        };
        let e = rot.symmetric_eigenvalues();
        if e.min() <= 0.0 {
            return Err(self.err(el, "the inertia is not positive definite"));
        }
        // A rigid body's principal moments satisfy the triangle inequality; MuJoCo's compiler
        // refuses an inertia that does not (rounding aside).
        if e.sum() - e.max() < e.max() * (1.0 - 1e-12) {
            return Err(self.err(el, format!("the principal moments {:?} violate A + B >= C, which no rigid body does (MuJoCo refuses them too): correct the inertia", e.as_slice())));
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
        if el.attr("tendon").is_some() || el.attr("site").is_some() || el.attr("body").is_some() {
            return Err(self.err(
                el,
                "only joint actuators are supported by SCM: give joint=\"NAME\"",
            ));
        }
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
        if self.limited(el, "forcelimited", "forcerange")?.is_some() {
            return Err(self.err(el, "forcerange is not supported by SCM yet: limit the control range (ctrlrange) instead"));
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
        let ctrlrange = match self.limited(el, "ctrllimited", "ctrlrange")? {
            Some(r) if r.0 > r.1 => return Err(self.err(el, "ctrlrange is reversed")),
            Some(_) if !self.flags.clampctrl => None,
            r => r,
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

    /// A range that applies as MuJoCo's `limited` attribute (true, false, or auto: given
    /// with `autolimits`) says.
    fn limited(
        &self,
        el: &Element,
        flag: &str,
        range: &str,
    ) -> Result<Option<(f64, f64)>, SceneError> {
        let r = self.floats(el, range, 2)?;
        let on = match el.attr(flag) {
            Some("true") => true,
            Some("false") => false,
            None | Some("auto") => r.is_some() && self.settings.autolimits,
            Some(v) => {
                return Err(self.err(el, format!("{flag}=\"{v}\": expected true, false or auto")))
            }
        };
        match (on, r) {
            (true, None) => Err(self.err(el, format!("{flag} without {range}"))),
            (true, Some(r)) => Ok(Some((r[0], r[1]))),
            (false, _) => Ok(None),
        }
    }

    /// `<fixed>` tendons are accepted where they add no force (no stiffness, damping, limits or
    /// actuator); anything else is refused.
    fn tendon(&mut self, el: &Element) -> Result<(), SceneError> {
        if el.name != "fixed" {
            return Err(self.err(
                el,
                "spatial tendons are not supported by SCM yet: remove the tendon and what uses it",
            ));
        }
        self.check_attrs(
            el,
            &[
                "name",
                "stiffness",
                "damping",
                "range",
                "limited",
                "springlength",
                "frictionloss",
                "armature",
            ],
        )?;
        for key in ["stiffness", "damping", "frictionloss", "armature"] {
            if self.float(el, key)?.is_some_and(|v| v != 0.0) {
                return Err(self.err(el, format!("tendon {key} is not supported by SCM yet: remove it, or put the spring or damper on the joints")));
            }
        }
        if self.limited(el, "limited", "range")?.is_some() && self.flags.limit {
            return Err(self.err(el, "tendon limits are not supported by SCM yet: remove the range, or switch limits off with <option><flag limit=\"disable\"/></option>"));
        }
        for j in &el.children {
            if j.name != "joint" {
                return Err(self.err(j, "a fixed tendon holds <joint> elements"));
            }
            let name = j
                .attr("joint")
                .ok_or_else(|| self.err(j, "joint=\"NAME\" is required"))?;
            if !self.joints.iter().any(|x| x.name == name) {
                return Err(self.err(j, format!("no joint named '{name}'")));
            }
        }
        self.unused(
            el,
            "fixed tendon without stiffness, damping, limits or actuator: it adds no force",
        );
        Ok(())
    }

    fn contact(&mut self, el: &Element) -> Result<(), SceneError> {
        for c in &el.children {
            match c.name.as_str() {
                "pair" => {
                    self.check_attrs(c, &["name", "geom1", "geom2", "friction", "condim"])?;
                    let friction = match c.attr("friction").map(parse_floats) {
                        None => None,
                        Some(Some(v)) if (1..=5).contains(&v.len()) && v[0] >= 0.0 => Some(v[0]),
                        Some(_) => {
                            return Err(
                                self.err(c, "friction: expected 1 to 5 non-negative numbers")
                            )
                        }
                    };
                    let friction = match c.attr("condim") {
                        Some("1") => Some(0.0),
                        _ => friction,
                    };
                    let g1 = c
                        .attr("geom1")
                        .ok_or_else(|| self.err(c, "geom1 is required"))?;
                    let g2 = c
                        .attr("geom2")
                        .ok_or_else(|| self.err(c, "geom2 is required"))?;
                    self.explicit_pairs
                        .push((g1.into(), g2.into(), friction, c.line));
                }
                "exclude" => {
                    self.check_attrs(c, &["name", "body1", "body2"])?;
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

    /// Body inertias as `<compiler>` says: from the geoms or `<inertial>`, bounded, scaled to
    /// the total mass.
    fn compile_inertias(&mut self) {
        let s = self.settings;
        for b in 1..self.bodies.len() {
            let from_geoms = match s.inertia_from_geom {
                InertiaFromGeom::Always => true,
                InertiaFromGeom::Auto => !self.explicit_inertia[b],
                InertiaFromGeom::Never => false,
            };
            if from_geoms {
                self.bodies[b].inertia = self.geom_inertia[b];
            }
            let i = &mut self.bodies[b].inertia;
            i.mass = i.mass.max(s.bound_mass);
            if s.bound_inertia > 0.0 {
                let e = i.rot.symmetric_eigen();
                let d = e.eigenvalues.map(|x| x.max(s.bound_inertia));
                i.rot = e.eigenvectors * Matrix3::from_diagonal(&d) * e.eigenvectors.transpose();
            }
        }
        if s.total_mass > 0.0 {
            let total: f64 = self.bodies.iter().map(|b| b.inertia.mass).sum();
            if total > 0.0 {
                let k = s.total_mass / total;
                for b in self.bodies.iter_mut().skip(1) {
                    b.inertia.mass *= k;
                    b.inertia.rot *= k;
                }
            }
        }
    }

    /// Applies the `<option><flag>` switches; returns what SCM refuses to simulate (features
    /// that change the physics and that SCM does not model), first in file order first.
    fn apply_flags(&mut self) -> Vec<SceneError> {
        let mut refused = Vec::new();
        let f = self.flags;
        // MuJoCo's default integrator is its Euler.
        let mujoco = self.option_integrator.unwrap_or(Integrator::DampedEuler);
        if !f.eulerdamp && mujoco == Integrator::DampedEuler {
            self.option_integrator = Some(Integrator::SemiImplicitEuler);
        }
        if !f.gravity {
            self.gravity = Vector3::zeros();
        }
        // MuJoCo (3, 4) computes gravity compensation with the passive forces, which it skips
        // when both springs and dampers are disabled (measured in MuJoCo 4.0).
        if !f.spring && !f.damper {
            for b in &mut self.bodies {
                b.gravcomp = 0.0;
            }
        }
        for j in &mut self.joints {
            if !f.frictionloss {
                j.frictionloss = 0.0;
            }
            if !f.spring {
                j.stiffness = 0.0;
            }
            if !f.damper {
                j.damping = 0.0;
            }
        }
        if let Some(el) = &self.fluid {
            if self.wind != Vector3::zeros() {
                refused.push(self.err(
                    el,
                    "wind is not supported by SCM's fluid forces yet: remove it (the fluid is then still)",
                ));
            }
        }
        if f.limit {
            for (j, (_, _, el)) in self
                .limits
                .iter()
                .enumerate()
                .filter_map(|(j, l)| l.as_ref().map(|l| (j, l)))
            {
                if self.joints[j].kind == JointKind::Ball {
                    refused.push(self.err(el, "ball joint limits are not supported by SCM yet: remove range (or set limited=\"false\"), or switch limits off with <option><flag limit=\"disable\"/></option>"));
                }
            }
        }
        if !f.actuation && !self.actuators.is_empty() {
            refused.push(SceneError {
                file: self.file.clone(),
                line: 0,
                element: "flag".into(),
                message: "actuation=\"disable\" with actuators is not supported by SCM: remove the actuators instead".into(),
            });
        }
        refused.extend(std::mem::take(&mut self.refused));
        refused.sort_by(|a, b| (a.file.as_str(), a.line).cmp(&(b.file.as_str(), b.line)));
        refused
    }

    /// The initial state: the reference configuration at rest with zero controls, or the
    /// `<key>` that `scm_keyframe` names (by `name`, or by its index among the keys), whose
    /// `qpos`, `qvel` and `ctrl` replace those they give. The other keys are noted as unused.
    #[allow(clippy::type_complexity)]
    fn initial_state(
        &mut self,
        tree: &Tree,
        keyframe: Option<(String, usize)>,
    ) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>), SceneError> {
        let mut q0 = tree.q0();
        let mut v0 = vec![0.0; tree.nv];
        let mut ctrl0 = vec![0.0; self.actuators.len()];
        let chosen = match &keyframe {
            None => None,
            Some((want, line)) => {
                let by_name = self
                    .keys
                    .iter()
                    .position(|k| k.attr("name") == Some(want.as_str()));
                let by_index = want
                    .trim()
                    .parse::<usize>()
                    .ok()
                    .filter(|&i| i < self.keys.len());
                match by_name.or(by_index) {
                    Some(i) => Some(i),
                    None => {
                        return Err(self.setting_error(
                            *line,
                            "scm_keyframe",
                            format!("no <key> named '{want}' (and no key of that index): the scene has {} key(s)", self.keys.len()),
                        ))
                    }
                }
            }
        };
        for (i, key) in self.keys.clone().iter().enumerate() {
            if Some(i) != chosen {
                self.unused(
                    key,
                    "keyframe not chosen as the initial state (scm_keyframe picks one)",
                );
                continue;
            }
            for (attr, what) in [
                ("act", "actuator activations"),
                ("mpos", "mocap positions"),
                ("mquat", "mocap orientations"),
            ] {
                if key.attr(attr).is_some() {
                    return Err(self.err(key, format!("{attr}: {what} in the initial key are not supported by SCM: set the mocap inputs instead, or remove it")));
                }
            }
            if self.float(key, "time")?.is_some_and(|t| t != 0.0) {
                self.warnings.push(format!(
                    "{}:{}: the key's time is not used: the FMU starts at the host's start time",
                    key.file, key.line
                ));
            }
            for (attr, target) in [("qpos", &mut q0), ("qvel", &mut v0), ("ctrl", &mut ctrl0)] {
                if let Some(s) = key.attr(attr) {
                    let v = parse_floats(s)
                        .filter(|v| v.len() == target.len())
                        .ok_or_else(|| {
                            element_error(
                                key,
                                format!("{attr}: expected {} finite numbers", target.len()),
                            )
                        })?;
                    *target = v;
                }
            }
        }
        Ok((q0, v0, ctrl0))
    }

    /// Limited slide and hinge joints get their smooth limit springs, stiffened by their
    /// effective inertia at the reference configuration ([`crate::dynamics::limit`]).
    fn set_limits(&self, tree: &mut Tree) {
        let q0 = tree.q0();
        let kin = tree.kinematics(&q0, &vec![0.0; tree.nv]);
        let m = tree.mass_matrix(&kin);
        for (j, limit) in self.limits.iter().enumerate() {
            let joint = &mut tree.joints[j];
            if let (Some((lo, hi, _)), JointKind::Slide | JointKind::Hinge) = (limit, joint.kind) {
                let inertia = m[(joint.dadr, joint.dadr)];
                joint.limit = Some(crate::dynamics::limit::JointLimit::from_solref(
                    *lo,
                    *hi,
                    self.solreflimit[j],
                    inertia,
                ));
            }
        }
    }

    /// The compiled model without colliders, and everything SCM would refuse about it.
    fn compiled(mut self) -> Result<Compiled, SceneError> {
        self.compile_inertias();
        let refused = self.apply_flags();
        let tree = self.tree()?;
        Ok(Compiled {
            tree,
            geoms: self.geoms,
            actuators: self.actuators,
            timestep: self.timestep.unwrap_or(DEFAULT_STEP),
            integrator: self.option_integrator.unwrap_or(Integrator::DampedEuler),
            limits: self
                .limits
                .into_iter()
                .map(|l| l.map(|(lo, hi, _)| (lo, hi)))
                .collect(),
            refused,
            unused: self.unused,
            warnings: self.warnings,
        })
    }

    fn tree(&self) -> Result<Tree, SceneError> {
        Tree::new(self.bodies.clone(), self.joints.clone(), self.gravity).map_err(|e| SceneError {
            file: self.file.clone(),
            line: 0,
            element: "body".into(),
            message: e.to_string(),
        })
    }

    fn finish(mut self) -> Result<Scene, SceneError> {
        self.compile_inertias();
        if let Some(first) = self.apply_flags().into_iter().next() {
            return Err(first);
        }
        let mut contact = ContactParams::default();
        let mut spacing = DEFAULT_SPACING;
        let mut step = self.timestep.unwrap_or(DEFAULT_STEP);
        let mut integrator = self.option_integrator.unwrap_or(Integrator::DampedEuler);
        let mut tolerance = 1e-6;
        let mut contact_points = 0.0;
        let mut keyframe: Option<(String, usize)> = None;
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
                "scm_keyframe" => keyframe = Some((value, line)),
                _ => return Err(self.setting_error(line, &name, "unknown SCM setting".into())),
            }
        }
        // With contacts switched off (<flag contact="disable">) no body collides.
        let (pairs, colliders) = if self.flags.contact {
            self.split_static_planes();
            let (pairs, colliding) = self.pairs()?;
            let mut colliders: Vec<Option<Collider>> = vec![None; self.bodies.len()];
            for (b, slot) in colliders.iter_mut().enumerate() {
                *slot = self.collider(b, &colliding, spacing)?;
            }
            let pairs = pairs
                .into_iter()
                .filter(|p| match (&colliders[p.a], &colliders[p.b]) {
                    (Some(Collider::HalfSpace { .. }), Some(Collider::HalfSpace { .. })) => false,
                    (Some(_), Some(_)) => true,
                    _ => false,
                })
                .collect();
            (pairs, colliders)
        } else {
            (vec![], vec![None; self.bodies.len()])
        };
        let mut tree = self.tree()?;
        if self.flags.limit {
            self.set_limits(&mut tree);
        }
        let (q0, v0, ctrl0) = self.initial_state(&tree, keyframe)?;
        let fluid = self.fluid_model(&tree);
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
            q0,
            v0,
            ctrl0,
            fluid,
        };
        Ok(Scene {
            model,
            geoms: self.geoms,
            warnings: self.warnings,
            unused: self.unused,
            meshes: self.meshes,
            meshdir: self.meshdir,
            includes: vec![],
        })
    }

    /// MuJoCo's inertia-box fluid model for the moving bodies with mass, when the medium has a
    /// density or a viscosity (and the passive forces are on: MuJoCo skips them all when
    /// springs and dampers are both disabled). Each body's box is taken in its principal axes
    /// as MuJoCo's compiler orients them: an `<inertial diaginertia>`'s frame, the frame of the
    /// body's one massive geom, else the eigenvectors of its inertia (for a body whose moments
    /// are equal in two axes, the quadratic drag then depends on which axes are taken, and
    /// MuJoCo's choice may differ).
    fn fluid_model(&self, tree: &Tree) -> Option<Fluid> {
        if self.medium == (0.0, 0.0) || (!self.flags.spring && !self.flags.damper) {
            return None;
        }
        let mut bodies = Vec::new();
        for (b, body) in tree.bodies.iter().enumerate().skip(1) {
            let i = &body.inertia;
            if !tree.body_moves(b) || i.mass < 1e-15 {
                continue;
            }
            let from_geoms = match self.settings.inertia_from_geom {
                InertiaFromGeom::Always => true,
                InertiaFromGeom::Auto => !self.explicit_inertia[b],
                InertiaFromGeom::Never => false,
            };
            let one_geom = self.mass_geom_frames.get(&b).filter(|f| f.len() == 1);
            let frame = match (from_geoms, self.inertial_axes.get(&b), one_geom) {
                (false, Some(q), _) => Some(*q),
                (true, _, Some(f)) => Some(f[0]),
                _ => None,
            };
            let axes = match frame {
                Some(q) => q.to_rotation_matrix().into_inner(),
                None => i.rot.symmetric_eigen().eigenvectors,
            };
            let moments = (axes.transpose() * i.rot * axes).diagonal();
            bodies.push(FluidBody::new(b, i.mass, axes, moments));
        }
        Some(Fluid {
            density: self.medium.0,
            viscosity: self.medium.1,
            bodies,
        })
    }

    /// A static body (welded to the world) may hold planes beside other geoms, as MuJoCo's
    /// worldbody usually does (floor and fixed obstacles); SCM's collider is one shape per
    /// body, so each such plane moves to a static body of its own, named after the plane
    /// (made unique), in the same frame. Nothing moves: the bodies are welded to the world.
    fn split_static_planes(&mut self) {
        let weld = filter::weld_bodies(&self.bodies);
        // New bodies are pushed below; only the bodies that existed before are visited.
        for (b, &w) in weld.iter().enumerate() {
            if w != 0 {
                continue;
            }
            let on_b: Vec<usize> = (0..self.geoms.len())
                .filter(|&g| self.geoms[g].body == b)
                .collect();
            let planes: Vec<usize> = on_b
                .iter()
                .copied()
                .filter(|&g| self.geoms[g].shape.is_none())
                .collect();
            if planes.is_empty() || (planes.len() == 1 && on_b.len() == 1) {
                continue;
            }
            for g in planes {
                let mut name = self.geoms[g].name.clone();
                while self.bodies.iter().any(|x| x.name == name) {
                    name.push('_');
                }
                let index = self.bodies.len();
                self.bodies.push(Body {
                    name,
                    parent: Some(b),
                    offset: Isometry3::identity(),
                    inertia: NO_INERTIA,
                    joints: vec![],
                    mocap: false,
                    gravcomp: 0.0,
                });
                self.explicit_inertia.push(false);
                self.geom_inertia.push(NO_INERTIA);
                self.geoms[g].body = index;
            }
        }
    }

    /// A body's collider from its geoms that can touch something: the exact half-space of a
    /// plane, or the AOPC of the union of the other geoms.
    fn collider(
        &self,
        b: usize,
        colliding: &[bool],
        spacing: f64,
    ) -> Result<Option<Collider>, SceneError> {
        let geoms: Vec<&Geom> = self
            .geoms
            .iter()
            .zip(colliding)
            .filter(|(g, &c)| c && g.body == b)
            .map(|(g, _)| g)
            .collect();
        if let Some(p) = geoms.iter().find(|g| g.shape.is_none()) {
            if geoms.len() > 1 {
                return Err(SceneError {
                    file: p.file.clone(),
                    line: p.line,
                    element: "geom".into(),
                    message: format!("plane '{}' shares moving body '{}' with other geoms: a plane belongs to a static body", p.name, self.bodies[b].name),
                });
            }
            return Ok(Some(Collider::HalfSpace {
                point: p.pose.translation.vector,
                normal: p.pose.rotation * Vector3::z(),
            }));
        }
        if geoms.is_empty() {
            return Ok(None);
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
                file: geoms[0].file.clone(),
                line: geoms[0].line,
                element: "geom".into(),
                message: format!("body '{}' (geoms {}) would get about {estimate:.3e} AOPC points at scm_spacing = {spacing} m (at most {MAX_AOPC_POINTS:e}): increase scm_spacing or make the geoms smaller", self.bodies[b].name, geoms.iter().map(|g| format!("'{}'", g.name)).collect::<Vec<_>>().join(", ")),
            });
        }
        let aopc = crate::geometry::union::sample_union(&parts, spacing);
        Ok(Some(Collider::Aopc(aopc)))
    }

    /// Colliding body pairs by MuJoCo's rules ([`filter`]), and which geoms collide at all.
    fn pairs(&mut self) -> Result<(Vec<Pair>, Vec<bool>), SceneError> {
        let body_of = |name: &str, line: usize, what: &str| -> Result<usize, SceneError> {
            self.bodies
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
        let mut explicit_friction = Vec::new();
        for (g1, g2, friction, line) in &self.explicit_pairs {
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
            explicit_friction.push(((x.min(y), x.max(y)), *friction));
        }
        let rules = filter::Rules {
            bodies: &self.bodies,
            geoms: &self.geoms,
            filterparent: self.flags.filterparent,
            excluded: &excluded,
            explicit: &explicit,
        };
        let weld = filter::weld_bodies(&self.bodies);
        // MuJoCo skips pairs where neither weld body has degrees of freedom (static or mocap).
        let moves = |b: usize| weld[b] != 0 && !self.bodies[weld[b]].joints.is_empty();
        let nb = self.bodies.len();
        let mut body_pairs = Vec::new();
        for a in 0..nb {
            for b in a + 1..nb {
                if (moves(a) || moves(b)) && rules.pair(&weld, a, b) {
                    body_pairs.push((a, b));
                }
            }
        }
        let colliding = rules.colliding_geoms(&weld, &body_pairs);
        // Say where whole-body contact reaches further than the bits.
        let mut notes = Vec::new();
        for &(a, b) in &body_pairs {
            if explicit.contains(&(a, b)) {
                continue;
            }
            for (g, _) in self
                .geoms
                .iter()
                .zip(&colliding)
                .filter(|(g, &c)| c && (g.body == a || g.body == b))
            {
                let other = if g.body == a { b } else { a };
                let any = self
                    .geoms
                    .iter()
                    .zip(&colliding)
                    .any(|(h, &c)| c && h.body == other && filter::compatible(g, h));
                if !any {
                    notes.push(format!(
                        "{}:{}: geom '{}' of body '{}' touches body '{}' in SCM although its contype/conaffinity exclude every geom of it (SCM's contact acts between whole bodies)",
                        g.file, g.line, g.name, self.bodies[g.body].name, self.bodies[other].name
                    ));
                }
            }
        }
        self.warnings.extend(notes);
        let pairs = body_pairs
            .into_iter()
            .map(|(a, b)| {
                let own = explicit_friction
                    .iter()
                    .find(|(k, _)| *k == (a, b))
                    .and_then(|(_, f)| *f);
                let friction = own.or_else(|| self.geom_friction(a, b, &colliding));
                Pair { a, b, friction }
            })
            .collect();
        Ok((pairs, colliding))
    }

    /// A body pair's friction from its geoms as MuJoCo combines them: the larger of the two
    /// geoms' sliding friction, none where both are frictionless (`condim="1"`); over a body's
    /// geoms, the largest. `None` when the scene sets `scm_friction`, which then applies to
    /// every pair without a `<pair friction>`.
    fn geom_friction(&mut self, a: usize, b: usize, colliding: &[bool]) -> Option<f64> {
        if self.numeric.iter().any(|(n, _, _)| n == "scm_friction") {
            return None;
        }
        let of = |body: usize| -> Vec<&Geom> {
            self.geoms
                .iter()
                .zip(colliding)
                .filter(|(g, &c)| c && g.body == body)
                .map(|(g, _)| g)
                .collect()
        };
        let (ga, gb) = (of(a), of(b));
        let combine = |x: &Geom, y: &Geom| {
            if x.condim == 1 && y.condim == 1 {
                0.0
            } else {
                x.friction.max(y.friction)
            }
        };
        let mut values: Vec<f64> = ga
            .iter()
            .flat_map(|x| {
                gb.iter()
                    .filter(|y| filter::compatible(x, y))
                    .map(|y| combine(x, y))
            })
            .collect();
        if values.is_empty() {
            // An explicit pair, or whole-body contact past the bits: every geom pair counts.
            values = ga
                .iter()
                .flat_map(|x| gb.iter().map(|y| combine(x, y)))
                .collect();
        }
        let mu = values
            .iter()
            .copied()
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        if values.iter().any(|&v| Some(v) != mu) {
            let (na, nb) = (self.bodies[a].name.clone(), self.bodies[b].name.clone());
            let list = values
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(", ");
            self.warnings.push(format!(
                "bodies '{na}' and '{nb}': their geoms combine to different friction coefficients ({list}); SCM's contact acts between whole bodies and uses the largest, {}",
                mu.unwrap_or(1.0)
            ));
        }
        Some(mu.unwrap_or(1.0))
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
    let in_fmu = scene.file_name().is_some_and(|n| n == SCENE_FILE)
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
