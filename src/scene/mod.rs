//! Scene loader: a subset of MuJoCo's MJCF (docs/mjcf.md), so the same file runs in MuJoCo and here.
//!
//! SCM settings come as `<custom><numeric name="scm_..." data="..."/>` (numbers) or
//! `<custom><text name="scm_..." data="..."/>` (names), which MuJoCo ignores. Visual-only
//! elements are skipped; a physics element or attribute we do not model is an error naming the
//! file, the line and the element.

mod actuator;
mod actuator_defaults;
mod assemble;
mod assets;
mod attach;
mod body;
mod builtin_mesh;
pub mod canonical;
mod collide;
mod compiled;
pub mod contact;
mod dampratio;
pub mod defaults;
mod equality;
pub mod filter;
mod fluid;
mod geom;
mod hfield;
pub mod include;
mod inline_mesh;
pub mod json;
mod mechanics;
mod mesh_weight;
mod names;
mod paths;
mod read;
mod replicate;
mod sdf;
mod self_attach;
mod settings;
mod smoothing;
mod surface;
mod tendon;
mod weights;
pub use assets::{MeshAsset, MeshInertia};
pub use collide::spacing_text;
pub use compiled::{compile, Compiled, CompiledPair};
use equality::{Anchors, ConnectSpec, EqualitySpec};
pub use hfield::HeightField;
pub use inline_mesh::InlineMesh;
pub use paths::{mesh_path, packed_mesh_name, packed_relative, scene_dir};
use read::{element_error, parse_floats, Place};
use settings::{advice, CompilerSettings, Flags, InertiaFromGeom, UNUSED_ATTRIBUTES};
use tendon::{SegmentSpec, TendonSpec};
pub mod xml;

use crate::collision::{Collider, Twist};
use crate::contact::{ContactParams, Dissipation};
use crate::dynamics::fluid::{Fluid, FluidBody};
use crate::dynamics::spatial::Inertia;
use crate::dynamics::{Body, Joint, JointKind, Tree, TreeError};
use crate::geometry::{Placement, Shape, Spacing, TriMesh};
use crate::integrate::Integrator;
use crate::model::{Activation, ActivationLaw, Actuator, ActuatorKind, Model, Pair, Transmission};
use canonical::Angles;
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use std::collections::HashMap;
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

/// A `<pair>` as read: its geoms, its own friction if given, its `solref` and `solimp` and its
/// `margin` (its own or its default class's, 0 if neither: MuJoCo does not take a pair's from
/// its geoms), its line.
#[derive(Clone, Debug)]
struct ExplicitPair {
    geoms: [String; 2],
    friction: Option<f64>,
    /// Its `condim` (default 3), which MuJoCo reads instead of its geoms': 1 keeps the pair
    /// frictionless, whatever `override` says.
    condim: u32,
    softness: contact::Softness,
    margin: f64,
    /// `adhesion` and `gap`, its own (0 if not given: MuJoCo does not take a pair's from its
    /// geoms).
    adhesion: f64,
    gap: f64,
    line: usize,
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
    /// Height field assets (`scm pack` carries their files).
    pub hfields: Vec<hfield::HeightField>,
    /// Each contact pair's law from the file's `solref` and `solimp`, in the model's pair
    /// order (`None`: the pair takes the scene's `scm_stiffness` and
    /// `scm_dissipation_velocity`).
    pub pair_laws: Vec<Option<contact::PairLaw>>,
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
    /// Whether its shape is its mesh's convex hull, as MuJoCo collides a mesh.
    pub by_hull: bool,
    /// The mesh a primitive was fitted to (`mesh=` on a sphere, capsule, cylinder, box or
    /// ellipsoid: MuJoCo's mesh-fitted primitive; docs/mjcf.md).
    pub fitted_to: Option<String>,
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
    /// `solref`, `solimp`, `solmix` and `priority`, which size its contacts' stiffness and
    /// damping ([`contact`]).
    pub softness: contact::GeomSoftness,
    /// `margin` (m, default 0): the geom's share of its contacts' margin (MuJoCo adds the two
    /// geoms', [`crate::model::Pair::margin`]).
    pub margin: f64,
    /// `adhesion` (N, default 0): the pull its contacts can hold (MuJoCo adds the two geoms',
    /// or takes the higher `priority`'s, [`crate::model::Pair::adhesion`]).
    pub adhesion: f64,
    /// `gap` (m, default 0): how far past the margin its adhesive contacts still pull (MuJoCo
    /// adds the two geoms').
    pub gap: f64,
    /// `surfacevel` (MuJoCo's moving surface): the linear and angular velocity of its surface's
    /// flow in the geom's frame, about the geom's origin; `None` for all zeros.
    pub surfacevel: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The file that declares the geom.
    pub file: String,
    /// Its line there.
    pub line: usize,
    /// The spacing its AOPC is sampled at, `None` for a plane or a geom that collides with
    /// nothing (docs/geometry.md, "Spacing per geom").
    pub spacing: Option<Spacing>,
    /// Why it has that spacing, for `scm check` (empty where `spacing` is `None`).
    pub spacing_reason: String,
    /// How many points of its body's cloud come from it, the faces inside the body's other
    /// geoms dropped (`None` where `spacing` is `None`).
    pub points: Option<usize>,
}

/// Default spacing between AOPC points when the scene gives no `scm_spacing` (m).
pub const DEFAULT_SPACING: f64 = 0.01;
/// Quads per feature length when the scene sets `scm_spacing` but no `scm_resolution`:
/// infinitely many, so that every geom is sampled at `scm_spacing`. With `scm_resolution` = N,
/// a geom whose feature length is above `N × scm_spacing` is sampled more coarsely, at N quads
/// per radius of curvature or per box half-extent (docs/geometry.md, "Spacing per geom", with
/// what that costs in accuracy).
pub const DEFAULT_RESOLUTION: f64 = f64::INFINITY;
/// Quads per feature length when the scene sets neither `scm_spacing` nor `scm_resolution`
/// (docs/geometry.md, "Spacing per geom"): a geom larger than 16 spacings is sampled graded,
/// as with `scm_resolution` = 16, so that a 10 m ground box loads and a body resting on a large
/// geom meets few of its points (which the measurements there show to be what keeps it still).
pub const AUTO_RESOLUTION: f64 = 16.0;
/// Largest sagitta (m) of a smooth geom's sampling when the scene sets neither `scm_spacing`
/// nor `scm_resolution` ([`crate::geometry::shapes::Shape::spacing_within`]; docs/geometry.md,
/// "Spacing per geom", with what it costs in accuracy).
pub const AUTO_SAGITTA: f64 = 5e-4;
/// Prefix of a per-geom spacing setting: `<numeric name="scm_spacing:GEOM" data="0.05"/>`.
pub const GEOM_SPACING_PREFIX: &str = "scm_spacing:";
/// Most AOPC points one body may get, estimated from its geoms' surface area before sampling
/// (a point per `scm_spacing`² of surface, at least three per mesh triangle). A body at the
/// limit takes about 650 MB (about 320 bytes per point with its BVH, see docs/performance.md)
/// and a pair evaluation at the scenes' ε seconds to minutes; a scene beyond it (a spacing of
/// 1e-9 m, a geom of a kilometre) would exhaust the host's memory, and an allocation failure
/// aborts the host's process: refused with an error instead.
pub const MAX_AOPC_POINTS: f64 = 2e6;

/// Estimated AOPC point count of a shape sampled at `sampling` ([`Shape::sample_spaced`]):
/// surface area / spacing², a box's faces counted on its grids (without the lines other geoms
/// add), at least three points per mesh triangle (an upper bound for the ellipsoid: its
/// bounding sphere).
fn estimated_points(shape: &Shape, sampling: &Spacing) -> f64 {
    use std::f64::consts::PI;
    let spacing = sampling.coarse.min();
    let area = match shape {
        Shape::Sphere { radius } => 4.0 * PI * radius * radius,
        Shape::Box { half } => {
            return crate::geometry::sample::box_quads(half, sampling, &Default::default())
        }
        Shape::Capsule {
            radius,
            half_length,
        } => 4.0 * PI * radius * radius + 4.0 * PI * radius * half_length,
        Shape::Cylinder {
            radius,
            half_length,
        } => 2.0 * PI * radius * radius + 4.0 * PI * radius * half_length,
        Shape::Ellipsoid { radii } => 4.0 * PI * radii.max().powi(2),
        Shape::Mesh(m) | Shape::Implicit { mesh: m, .. } => {
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

/// Parses, expands includes, reads compiler and defaults, canonicalizes and reads the tree.
fn read(text: &str, path: &Path) -> Result<(Builder, Vec<include::IncludedFile>), SceneError> {
    let (mut b, root, files) = prepare(text, path, &mut vec![path.to_path_buf()])?;
    b.scene(&root)?;
    Ok((b, files))
}

/// A file read up to its canonical tree: parsed, its includes expanded, its compiler settings
/// and default classes read, the models it attaches brought in (`chain`: the files attaching,
/// outermost first), its replicates expanded, its names checked, its tree canonical. Returns
/// the builder holding its compiler settings, the tree, and the files read besides `path`.
fn prepare(
    text: &str,
    path: &Path,
    chain: &mut Vec<std::path::PathBuf>,
) -> Result<(Builder, Element, Vec<include::IncludedFile>), SceneError> {
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
    let mut files = include::expand(&mut root, path)?;
    let mut defaults = defaults::Defaults::default();
    for el in &root.children {
        match el.name.as_str() {
            "compiler" => b.compiler(el)?,
            "default" => defaults.read(el)?,
            _ => {}
        }
    }
    // Stray text as written (a replicate's once, not once per copy); replicates placed in the
    // compiler's angle unit and sequence, before the names are read; then the attached models,
    // copy by copy of a replicate that holds them (MuJoCo's order of their actuators).
    b.stray_text(&root);
    replicate::expand(&mut root, &b.angles)?;
    files.extend(attach::expand(&mut root, &mut b, path, chain)?);
    b.names = names::Names::read(&root)?;
    canonical::canonicalize(&mut root, &defaults, &b.angles)?;
    Ok((b, root, files))
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
    /// Height fields by name: their `size` (x and y half-extents, elevation scale, base
    /// depth). SCM takes only flat ones (`Builder::hfield_asset`).
    hfields: Vec<hfield::HeightField>,
    bodies: Vec<Body>,
    /// Where each body is written, by name (for errors the tree finds).
    body_places: HashMap<String, Place>,
    joints: Vec<Joint>,
    geoms: Vec<Geom>,
    actuators: Vec<Actuator>,
    gravity: Vector3<f64>,
    timestep: Option<f64>,
    option_integrator: Option<Integrator>,
    /// `<option>`'s `o_margin`, `o_solref`, `o_solimp`, `o_friction` (under `override`).
    contact_override: contact::ContactOverride,
    /// `<custom><numeric>` and `<text>` SCM settings: name, value, where they were read.
    numeric: Vec<(String, f64, Place)>,
    text: Vec<(String, String, Place)>,
    /// `<pair geom1 geom2 friction>`: the names, the sliding friction if given, the line.
    explicit_pairs: Vec<ExplicitPair>,
    excludes: Vec<(String, String, usize)>,
    /// Whether each body's inertia came from `<inertial>`.
    explicit_inertia: Vec<bool>,
    /// Each body's inertia from its geoms (used as `inertiafromgeom` says).
    geom_inertia: Vec<Inertia>,
    warnings: Vec<String>,
    /// Elements and attributes accepted and unused by SCM (file:line: what, why).
    unused: Vec<String>,
    flags: Flags,
    /// `<option cone impratio>`, which size each pair's law ([`contact::cone_share`]).
    cone: contact::Cone,
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
    /// The geoms of MuJoCo's ellipsoid fluid model (`fluidshape="ellipsoid"`), their
    /// `fluidcoef`, and for a mesh its inertia frame (in the geom's) and semi-axes there.
    fluid_ellipsoids: Vec<fluid::FluidEllipsoid>,
    /// Orientation of each `<inertial diaginertia>` (its principal axes).
    inertial_axes: std::collections::BTreeMap<usize, UnitQuaternion<f64>>,
    /// Orientation of each geom that gives its body mass, per body.
    mass_geom_frames: std::collections::BTreeMap<usize, Vec<UnitQuaternion<f64>>>,
    /// Whether each joint is limited (`range` and line, SI units) by `limited` or `autolimits`.
    limits: Vec<Option<(f64, f64, Element)>>,
    /// Each joint's `solreflimit` and `solimplimit` (MuJoCo's defaults `0.02 1` and `0.9 0.95
    /// 0.001 0.5 2`).
    limit_softness: Vec<contact::Softness>,
    /// `<tendon><fixed>` elements, as read.
    tendons: Vec<TendonSpec>,
    /// `<tendon><spatial>` elements, as read (their `joints` empty).
    spatial_tendons: Vec<(TendonSpec, Vec<SegmentSpec>)>,
    /// The sites (`site=`, with their gears) and slider-cranks that actuators drive.
    transmissions: actuator::Transmissions,
    /// The instances of `<extension>` plugins, by name (`sdf.rs`).
    sdf_instances: std::collections::HashMap<String, sdf::SdfInstance>,
    /// `<equality><joint>` and `<equality><tendon>` elements, as read.
    equalities: Vec<EqualitySpec>,
    /// `<equality><connect>` and `<equality><weld>` elements, as read.
    connects: Vec<ConnectSpec>,
    /// Named sites: body and pose in its frame (what connects and welds between sites read);
    /// `None` for a site placed by `fromto`.
    sites: std::collections::HashMap<String, Option<(usize, Isometry3<f64>)>>,
    /// The names the scene gives, per kind (and those made up for unnamed objects).
    names: names::Names,
    /// Each actuator's `dampratio` (position actuators that give one), like `actuators`.
    dampratios: Vec<Option<(f64, Place)>>,
    /// Joints with `springdamper="τ ζ"`: index, time constant, damping ratio.
    springdampers: Vec<(usize, f64, f64)>,
    /// Joints whose total actuator force is limited (`actuatorfrcrange`): index, range.
    actuator_ranges: Vec<(usize, f64, f64)>,
    /// The geoms written `type="sdf"`: MuJoCo collides them by their mesh's distance field.
    sdf_geoms: Vec<usize>,
}

impl Builder {
    /// The name an element gives (`None` when it gives none, or an empty one: MuJoCo treats
    /// `name=""` as no name).
    fn given_name(el: &Element) -> Option<String> {
        el.attr("name")
            .filter(|n| !n.is_empty())
            .map(str::to_string)
    }

    fn new(file: String) -> Self {
        Builder {
            file,
            angles: Angles::default(),
            settings: CompilerSettings::default(),
            meshdir: None,
            meshes: vec![],
            hfields: vec![],
            body_places: HashMap::new(),
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
            contact_override: contact::ContactOverride::default(),
            numeric: vec![],
            text: vec![],
            names: names::Names::default(),
            dampratios: vec![],
            springdampers: vec![],
            actuator_ranges: vec![],
            sdf_geoms: vec![],
            explicit_pairs: vec![],
            excludes: vec![],
            explicit_inertia: vec![false],
            geom_inertia: vec![NO_INERTIA],
            warnings: vec![],
            unused: vec![],
            flags: Flags::default(),
            cone: contact::Cone::default(),
            fluid: None,
            medium: (0.0, 0.0),
            wind: Vector3::zeros(),
            fluid_ellipsoids: Vec::new(),
            inertial_axes: Default::default(),
            mass_geom_frames: Default::default(),
            keys: vec![],
            refused: vec![],
            limits: vec![],
            limit_softness: vec![],
            tendons: vec![],
            equalities: vec![],
            connects: vec![],
            spatial_tendons: vec![],
            transmissions: Default::default(),
            sdf_instances: Default::default(),
            sites: Default::default(),
        }
    }

    fn scene(&mut self, root: &Element) -> Result<(), SceneError> {
        self.check_attrs(root, &["model"])?;
        // Settings first: they apply wherever they appear in the file (the compiler and the
        // defaults were read before the tree was made canonical).
        for el in &root.children {
            match el.name.as_str() {
                "option" => self.option(el)?,
                "custom" => self.custom(el)?,
                "extension" => self.extension(el)?,
                _ => {}
            }
        }
        // Assets next (they may come after the bodies that use them).
        for el in root.children.iter().filter(|e| e.name == "asset") {
            for a in &el.children {
                match a.name.as_str() {
                    "texture" | "material" | "skin" | "model" => self.unused(a, "renderer asset"),
                    "mesh" => self.mesh_asset(a)?,
                    "hfield" => self.hfield_asset(a)?,
                    _ => return Err(self.err(a, "unknown asset")),
                }
            }
        }
        // Every <worldbody> (an included file may bring another) adds to the one world body,
        // as in MuJoCo: its own geoms and sites first, then its bodies.
        let world = root
            .children
            .iter()
            .filter(|el| el.name == "worldbody")
            .flat_map(|el| el.children.iter());
        self.body_children(world, 0)?;
        for el in &root.children {
            match el.name.as_str() {
                "compiler" | "option" | "default" | "custom" | "asset" | "worldbody" => {}
                // After everything else: an actuator names joints and tendons wherever they
                // are declared, as MuJoCo resolves names after reading the whole file.
                "actuator" => {}
                "contact" => self.contact(el)?,
                // After the bodies: a tendon names joints wherever they are declared (an
                // included file may declare the tendons before the joints, as MuJoCo allows).
                "tendon" => {}
                // After the tendons: a tendon equality names them (see below).
                "equality" => {}
                "visual" | "statistic" | "size" => self.unused(el, "renderer and memory settings"),
                // Read first (above): a plugin SCM does not run is refused where it is used.
                "extension" => {}
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
        for el in root.children.iter().filter(|el| el.name == "tendon") {
            for t in &el.children {
                self.tendon(t)?;
            }
        }
        for el in root.children.iter().filter(|el| el.name == "equality") {
            // Switched off, the constraints are not read: what SCM does not model among them
            // (flex equalities, sites placed by fromto) must not stop a file that asks for
            // none of them.
            if !self.flags.equality && !el.children.is_empty() {
                self.unused(
                    el,
                    "equality constraints switched off by <flag equality=\"disable\">",
                );
                continue;
            }
            for e in &el.children {
                self.equality(e)?;
            }
        }
        for el in root.children.iter().filter(|el| el.name == "actuator") {
            for a in &el.children {
                self.actuator(a)?;
            }
        }
        Ok(())
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
