//! Bodies, joints and inertials: the kinematic tree as the file writes it.

use super::*;

impl Builder {
    pub(super) fn body_child(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
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
            "site" => self.site(el, body),
            "camera" | "light" => Ok(()),
            "composite" | "flexcomp" | "skin" | "attach" | "plugin" => Err(self.err(
                el,
                format!("<{}> is not supported by SCM: SCM simulates rigid bodies with body, joint, geom, inertial (sites, cameras and lights are accepted)", el.name),
            )),
            _ => Err(self.err(el, "unsupported element in a body: SCM reads body, joint, freejoint, geom, inertial, site, camera and light")),
        }
    }

    /// A `<site>`: its body and pose are kept under its name, for the equalities that name it;
    /// a site is not simulated otherwise (its other attributes are not read).
    fn site(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
        let Some(name) = Self::given_name(el) else {
            return Ok(());
        };
        // A fromto site's frame follows from its type; SCM does not place one yet and says so
        // where an equality names it.
        let place = match el.attr("fromto") {
            None => Some((body, self.pose(el)?)),
            Some(_) => None,
        };
        self.sites.insert(name, place);
        Ok(())
    }

    pub(super) fn body(&mut self, el: &Element, parent: usize) -> Result<(), SceneError> {
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
        let name = match Self::given_name(el) {
            Some(n) => n,
            None => self.names.make("body", format!("body{index}")),
        };
        let offset = self.pose(el)?;
        self.body_places.insert(name.clone(), Place::of(el));
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
        // Known before the geoms are read (an <inertial> may come after them): whether the
        // body's mass comes from its geoms decides whether a geom's mesh must be closed.
        self.explicit_inertia
            .push(el.children.iter().any(|c| c.name == "inertial"));
        self.geom_inertia.push(NO_INERTIA);
        self.body_children(el.children.iter(), index)
    }

    /// A body's children, as MuJoCo lists them: what belongs to the body itself (joints,
    /// geoms, sites, in file order) before its child bodies, wherever the file writes them, so
    /// that joints, coordinates and geoms are numbered body by body (depth first) as in
    /// MuJoCo's compiled model.
    pub(super) fn body_children<'a>(
        &mut self,
        children: impl Iterator<Item = &'a Element> + Clone,
        body: usize,
    ) -> Result<(), SceneError> {
        for child in children.clone().filter(|c| c.name != "body") {
            self.body_child(child, body)?;
        }
        for child in children.filter(|c| c.name == "body") {
            self.body_child(child, body)?;
        }
        Ok(())
    }

    pub(super) fn joint(
        &mut self,
        el: &Element,
        body: usize,
        free: bool,
    ) -> Result<(), SceneError> {
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
                    "solimplimit",
                    "actuatorfrcrange",
                    "actuatorfrclimited",
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
        // MuJoCo's rules for the joints of one body: no rotation after a ball joint (the ball
        // already turns the body every way), and at most 6 degrees of freedom.
        let before: Vec<JointKind> = self.bodies[body]
            .joints
            .iter()
            .map(|&j| self.joints[j].kind)
            .collect();
        if matches!(kind, JointKind::Ball | JointKind::Hinge) && before.contains(&JointKind::Ball) {
            return Err(self.err(el, format!("a rotation after the ball joint of body '{}': MuJoCo refuses it too (the ball already turns the body every way)", self.bodies[body].name)));
        }
        let dofs = |k: &JointKind| match k {
            JointKind::Free => 6,
            JointKind::Ball => 3,
            _ => 1,
        };
        // (A free joint beside others has its own message, where the tree is built.)
        let free_too = kind == JointKind::Free || before.contains(&JointKind::Free);
        if !free_too && before.iter().chain([&kind]).map(dofs).sum::<usize>() > 6 {
            return Err(self.err(
                el,
                format!(
                    "more than 6 degrees of freedom in body '{}': MuJoCo refuses it too",
                    self.bodies[body].name
                ),
            ));
        }
        // `springdamper="τ ζ"`: stiffness and damping from the joint's inertia at qpos0, once
        // the tree is known (`apply_springdampers`); "0 0" (MuJoCo's default) is none.
        let springdamper = match self.floats(el, "springdamper", 2)? {
            Some(v) if v == [0.0, 0.0] => None,
            Some(v) if v[0] > 0.0 && v[1] > 0.0 => {
                if !matches!(kind, JointKind::Slide | JointKind::Hinge) {
                    return Err(self.err(el, "springdamper on a free or ball joint is not supported by SCM: give stiffness and damping"));
                }
                Some((v[0], v[1]))
            }
            Some(_) => {
                return Err(self.err(
                    el,
                    "springdamper: both values (time constant, damping ratio) must be positive (MuJoCo refuses it too)",
                ))
            }
            None => None,
        };
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
        let index = self.joints.len();
        let name = match Self::given_name(el) {
            Some(n) => n,
            // A free joint without a name is named after its body, however it is written.
            None if kind == JointKind::Free => {
                self.names.make("joint", self.bodies[body].name.clone())
            }
            None => {
                let base = format!(
                    "{}_joint{}",
                    self.bodies[body].name,
                    self.bodies[body].joints.len()
                );
                self.names.make("joint", base)
            }
        };
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
        if let Some((tau, zeta)) = springdamper {
            self.springdampers.push((self.joints.len(), tau, zeta));
        }
        // MuJoCo clamps the total actuator force on a limited slide or hinge joint; it ignores
        // the range on a ball or free joint, and a reversed one.
        match self.limited(el, "actuatorfrclimited", "actuatorfrcrange")? {
            None => {}
            Some(_) if !matches!(kind, JointKind::Slide | JointKind::Hinge) => self.unused(
                el,
                "actuatorfrcrange: MuJoCo clamps actuator forces on slide and hinge joints only",
            ),
            // Written limited and reversed: MuJoCo refuses it.
            Some((lo, hi)) if lo > hi && el.attr("actuatorfrclimited") == Some("true") => {
                return Err(self.err(el, "actuatorfrcrange is reversed (MuJoCo refuses it too)"))
            }
            // Limited by autolimits, an empty or reversed range limits nothing in MuJoCo.
            Some((lo, hi)) if lo >= hi => self.unused(
                el,
                "actuatorfrcrange: empty or reversed, so MuJoCo does not limit the joint's actuator force (nor does SCM)",
            ),
            Some((lo, hi)) => self.actuator_ranges.push((self.joints.len(), lo, hi)),
        }
        self.joints.push(joint);
        self.limits.push(limit);
        let softness = self.limit_softness_of(el)?;
        self.limit_softness.push(softness);
        self.bodies[body].joints.push(index);
        Ok(())
    }

    pub(super) fn inertial(&mut self, el: &Element, body: usize) -> Result<(), SceneError> {
        self.check_attrs(el, &["pos", "quat", "mass", "diaginertia", "fullinertia"])?;
        let mass = self
            .float(el, "mass")?
            .ok_or_else(|| self.err(el, "mass is required"))?;
        // A zero mass (and inertia) is MuJoCo's massless frame: allowed on a body welded to
        // one that carries the mass; a moving body without mass is refused with the tree.
        if mass < 0.0 {
            return Err(self.err(el, format!("mass=\"{mass}\" must not be negative")));
        }
        let pose = self.pose(el)?;
        let rot = match (
            self.vec3(el, "diaginertia")?,
            self.floats(el, "fullinertia", 6)?,
        ) {
            (Some(d), None) if d.min() < 0.0 => {
                return Err(self.err(el, "diaginertia must not be negative"))
            }
            (Some(d), None) => {
                self.inertial_axes.insert(body, pose.rotation);
                Matrix3::from_diagonal(&d)
            }
            (None, Some(f)) => {
                let full = Matrix3::new(f[0], f[3], f[4], f[3], f[1], f[5], f[4], f[5], f[2]);
                if full.symmetric_eigenvalues().min() <= 0.0 {
                    return Err(self.err(
                        el,
                        "fullinertia is not positive definite (MuJoCo refuses it too)",
                    ));
                }
                full
            }
            // Without either, MuJoCo's inertia is zero: a point mass (refused with the tree on a
            // body that moves, as MuJoCo refuses it).
            (None, None) => {
                self.inertial_axes.insert(body, pose.rotation);
                Matrix3::zeros()
            }
            (Some(_), Some(_)) => {
                return Err(self.err(
                    el,
                    "give diaginertia or fullinertia, not both (MuJoCo refuses both too)",
                ))
            }
        };
        let e = rot.symmetric_eigenvalues();
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

    pub(super) fn bits(&self, el: &Element, key: &str) -> Result<u32, SceneError> {
        match el.attr(key) {
            None => Ok(1),
            Some(s) => s
                .parse::<u32>()
                .map_err(|_| self.err(el, format!("{key}=\"{s}\" must be a non-negative integer"))),
        }
    }
}
