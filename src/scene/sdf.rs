//! MuJoCo's SDF plugins: `<extension><plugin plugin="mujoco.sdf.torus"><instance name>` with
//! its `<config key value>`s, a `<mesh>` made by an instance (`<plugin instance="NAME"/>`),
//! and `<geom type="sdf">` on such a mesh. MuJoCo needs the plugin because its collision is
//! convex; SCM's SSDF takes the closed surface the distance function bounds
//! ([`ImplicitShape`]), which then weighs as any closed mesh and collides by that surface,
//! never by its convex hull.

use super::inline_mesh::InlineMesh;
use super::*;
use crate::geometry::implicit::ImplicitShape;

/// An instance of an SDF plugin: the plugin's name and the `<instance>` element.
pub(super) type SdfInstance = (String, Element);

/// MuJoCo's SDF plugins SCM makes shapes of.
const KNOWN: [&str; 5] = [
    "mujoco.sdf.torus",
    "mujoco.sdf.bowl",
    "mujoco.sdf.bolt",
    "mujoco.sdf.nut",
    "mujoco.sdf.gear",
];

/// Configuration keys that may be zero or negative (a gear's turn; a negative bore asks for
/// the plugin's own); the others must be positive.
const SIGNED_KEYS: [&str; 2] = ["alpha", "innerdiameter"];

impl Builder {
    /// `<extension>`: the instances of every plugin, kept by name for the meshes that use
    /// them (a plugin SCM does not run is refused where it is used).
    pub(super) fn extension(&mut self, el: &Element) -> Result<(), SceneError> {
        for p in &el.children {
            if p.name != "plugin" {
                return Err(self.err(p, "an <extension> holds <plugin> elements"));
            }
            let plugin = p.attr("plugin").unwrap_or_default().to_string();
            // (`mujoco.pid` is built where an actuator uses it: `Builder::pid_as_general`.)
            if !KNOWN.contains(&plugin.as_str()) && plugin != "mujoco.pid" {
                self.unused(
                    p,
                    "engine plugins, declared (an element that uses one is refused at its line)",
                );
            }
            for i in p.children.iter().filter(|c| c.name == "instance") {
                let Some(name) = i.attr("name") else {
                    return Err(self.err(i, "a plugin instance needs a name"));
                };
                if self.sdf_instances.contains_key(name) {
                    return Err(self.err(i, format!("plugin instance '{name}' is declared twice")));
                }
                self.sdf_instances
                    .insert(name.to_string(), (plugin.clone(), i.clone()));
            }
        }
        Ok(())
    }

    /// A `<mesh>` made by an SDF plugin (its `<plugin instance="NAME"/>` child, or a
    /// `<plugin plugin="...">` with its own `<config>`s): the plugin's shape as a closed
    /// surface on MuJoCo's grid, weighed by the mesh's inertia rule.
    pub(super) fn sdf_mesh(
        &mut self,
        el: &Element,
        p: &Element,
        (inertia, maxhullvert): (MeshInertia, Option<i64>),
    ) -> Result<(), SceneError> {
        let (plugin, config) = match p.attr("instance") {
            Some(name) => match self.sdf_instances.get(name) {
                Some((plugin, i)) => (plugin.clone(), i.clone()),
                None => {
                    return Err(self.err(
                        p,
                        format!("no plugin instance named '{name}' (declare it in <extension>)"),
                    ))
                }
            },
            None => (p.attr("plugin").unwrap_or_default().to_string(), p.clone()),
        };
        let shape = self.implicit_shape(el, &plugin, &config)?;
        let name = Self::given_name(el).ok_or_else(|| {
            self.err(
                el,
                "a mesh made by a plugin needs a name (MuJoCo refuses it too)",
            )
        })?;
        if self.meshes.iter().any(|m| m.name == name) {
            return Err(self.err(el, format!("mesh name '{name}' is used twice")));
        }
        for key in ["refpos", "refquat"] {
            if el.attr(key).is_some() {
                return Err(self.err(el, format!("{key} on a mesh made by an SDF plugin is not supported by SCM: place the geom instead (pos, quat)")));
            }
        }
        let placement = self.mesh_placement(el)?;
        if placement.scale != Vector3::repeat(1.0) {
            return Err(self.err(el, "scale is not compatible with a mesh made by an SDF plugin (MuJoCo refuses it too): scale the plugin's configuration instead"));
        }
        let origin = format!("made by the {plugin} plugin");
        let (vertices, faces) = shape.triangles();
        let label = format!("'{name}' ({origin})");
        let (mesh, problem) =
            self.surface_of(el, TriMesh::new(&label, vertices.clone(), faces.clone()))?;
        self.add_mesh(
            el,
            MeshAsset {
                inline: Some(InlineMesh {
                    vertices,
                    faces: Some(faces),
                    origin,
                    plugin: true,
                }),
                implicit: Some(shape),
                ..MeshAsset::read(name, placement, (inertia, maxhullvert), (mesh, problem))
            },
        );
        Ok(())
    }

    /// The shape a plugin of name `plugin` makes with the `<config>`s of `config` (MuJoCo's
    /// defaults for those not given).
    fn implicit_shape(
        &mut self,
        el: &Element,
        plugin: &str,
        config: &Element,
    ) -> Result<ImplicitShape, SceneError> {
        let keys: &[(&str, f64)] = match plugin {
            "mujoco.sdf.torus" => &[("radius1", 0.35), ("radius2", 0.15)],
            "mujoco.sdf.bowl" => &[("height", 0.4), ("radius", 1.0), ("thickness", 0.02)],
            "mujoco.sdf.bolt" | "mujoco.sdf.nut" => &[("radius", 0.26)],
            "mujoco.sdf.gear" => &[
                ("alpha", 0.0),
                ("diameter", 2.8),
                ("teeth", 25.0),
                ("thickness", 0.2),
                ("innerdiameter", -1.0),
            ],
            _ => {
                return Err(self.err(el, format!(
                    "this mesh is made by the engine plugin '{plugin}', which SCM does not run (it makes the shapes of {}): give its surface as a mesh file (OBJ or STL) with file=\"...\"",
                    KNOWN.join(", ")
                )))
            }
        };
        let mut values: Vec<f64> = keys.iter().map(|(_, v)| *v).collect();
        for c in config.children.iter().filter(|c| c.name == "config") {
            let key = c.attr("key").unwrap_or_default();
            let Some(k) = keys.iter().position(|(n, _)| *n == key) else {
                self.unused(
                    c,
                    format!(
                        "config key '{key}' ({plugin} reads {})",
                        keys.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                    ),
                );
                continue;
            };
            let signed = SIGNED_KEYS.contains(&key);
            values[k] = match c.attr("value").map(|v| v.trim().parse::<f64>()) {
                Some(Ok(v)) if v.is_finite() && (signed || v > 0.0) => v,
                _ => {
                    let what = if signed {
                        "a number"
                    } else {
                        "a positive number"
                    };
                    return Err(self.err(c, format!("config '{key}': expected {what}")));
                }
            };
        }
        Ok(match plugin {
            "mujoco.sdf.gear" => {
                let teeth = values[2];
                ImplicitShape::Gear {
                    alpha: values[0],
                    diameter: values[1],
                    teeth,
                    thickness: values[3],
                    inner: values[4],
                }
            }
            "mujoco.sdf.bolt" => ImplicitShape::Bolt { radius: values[0] },
            "mujoco.sdf.nut" => ImplicitShape::Nut { radius: values[0] },
            "mujoco.sdf.torus" => ImplicitShape::Torus {
                major: values[0],
                minor: values[1],
            },
            _ if values[0] >= values[1] => {
                return Err(self.err(
                    el,
                    format!(
                        "the bowl's height {} must be below its radius {}",
                        values[0], values[1]
                    ),
                ))
            }
            _ => ImplicitShape::Bowl {
                height: values[0],
                radius: values[1],
                thickness: values[2],
            },
        })
    }
}

impl Builder {
    /// An actuator computed by MuJoCo's `mujoco.pid` plugin, as the `<general>` it equals,
    /// with the integral's law where it has one. Without `ki` the plugin's
    /// `force = kp (u - L) - kd L̇` (`L` the actuator's length) is `gainprm="kp 0 0"` with
    /// `biasprm="0 -kp -kd"`. With `ki` it keeps its error integral `I` as an activation
    /// (MuJoCo's `actdim="1"`): the `<general>` with `gainprm="1 0 0"` reads `kp u + ki I⁺`
    /// ([`ActivationLaw::PidIntegral`]), whose step the assembly fills in from the file's. The
    /// slew limit (`slewmax`) keeps the last control, which it reads only after the first
    /// step (`time > 0`): refused. Any other plugin is refused.
    pub(super) fn pid_as_general(
        &mut self,
        el: &Element,
    ) -> Result<(Element, Option<ActivationLaw>), SceneError> {
        let (plugin, config) = match el.attr("instance") {
            Some(name) => match self.sdf_instances.get(name) {
                Some((plugin, i)) => (plugin.clone(), i.clone()),
                None => {
                    return Err(self.err(
                        el,
                        format!("no plugin instance named '{name}' (declare it in <extension>)"),
                    ))
                }
            },
            None => (
                el.attr("plugin").unwrap_or_default().to_string(),
                el.clone(),
            ),
        };
        if plugin != "mujoco.pid" {
            return Err(self.err(
                el,
                format!("an actuator computed by the engine plugin {plugin} is not supported by SCM: give a <position>, <velocity> or <general> actuator its gains instead"),
            ));
        }
        // With activation dynamics the plugin reads the activation and adds kd times its rate.
        if el.attr("dyntype").is_some_and(|d| d.trim() != "none") {
            return Err(self.err(el, "a PID plugin actuator with activation dynamics (dyntype) is not supported by SCM: leave dyntype out"));
        }
        let mut gains = [("kp", 0.0), ("kd", 0.0), ("ki", 0.0), ("imax", f64::NAN)];
        for c in config.children.iter().filter(|c| c.name == "config") {
            let key = c.attr("key").unwrap_or_default();
            let value = c.attr("value").unwrap_or_default();
            let number = value.trim().parse::<f64>().ok().filter(|v| v.is_finite());
            match (key, number) {
                ("slewmax", _) => {
                    return Err(self.err(c, "the PID plugin's slewmax keeps the last control and limits the next one's change only after the first step (time > 0), a state SCM's actuators do not have: leave it out, or filter the control with dyntype=\"filter\" on a <general> actuator"));
                }
                ("imax", Some(v)) if v < 0.0 => {
                    return Err(self.err(c, format!("imax=\"{v}\" is negative (MuJoCo refuses it too): give the largest force of the integral term, 0 or more")));
                }
                ("kp" | "kd" | "ki" | "imax", Some(v)) => {
                    for g in gains.iter_mut().filter(|g| g.0 == key) {
                        g.1 = v;
                    }
                }
                ("kp" | "kd" | "ki" | "imax", None) => {
                    return Err(self.err(
                        c,
                        format!("{key}=\"{value}\": expected one finite number"),
                    ))
                }
                _ => {
                    return Err(self.err(
                        c,
                        format!("'{key}' is not a configuration of the PID plugin (kp, ki, kd, imax, slewmax)"),
                    ))
                }
            }
        }
        let [(_, kp), (_, kd), (_, ki), (_, imax)] = gains;
        // MuJoCo's plugin asks for one activation for the integral, none without it.
        let expected = usize::from(ki != 0.0);
        let actdim = match el.attr("actdim").map(|v| v.trim().parse::<usize>()) {
            None => 0,
            Some(Ok(n)) => n,
            Some(Err(_)) => {
                return Err(self.err(el, "actdim: expected a whole number of activations"))
            }
        };
        if actdim != expected {
            return Err(self.err(el, format!("actdim=\"{actdim}\", but this PID keeps {expected} activation{} (MuJoCo refuses it too): write actdim=\"{expected}\"", if expected == 1 { "" } else { "s" })));
        }
        let mut general = el.clone();
        general.name = "general".into();
        general.children.clear();
        let drop = |k: &str| matches!(k, "plugin" | "instance" | "actdim");
        general.attrs.retain(|(k, _)| !drop(k));
        // The plugin's imax is a force: the integral's clamp is imax / ki.
        let bound = (ki != 0.0 && !imax.is_nan()).then_some(imax / ki);
        if bound.is_some_and(|b| b < 0.0) {
            return Err(self.err(el, format!("imax / ki = {imax} / {ki} is negative, which MuJoCo refuses (\"negative imax\"): give ki and imax the same sign")));
        }
        let law = (ki != 0.0).then_some(ActivationLaw::PidIntegral {
            kp,
            ki,
            bound,
            step: f64::NAN,
        });
        let gain = if law.is_some() { 1.0 } else { kp };
        general
            .attrs
            .push(("gainprm".into(), format!("{gain} 0 0")));
        general
            .attrs
            .push(("biasprm".into(), format!("0 {} {}", -kp, -kd)));
        general.attrs.push(("biastype".into(), "affine".into()));
        Ok((general, law))
    }
}
