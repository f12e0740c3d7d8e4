//! Actuators, joint limits' settings, tendons and the `<contact>` section (`exclude`, `pair`).

use super::*;

impl Builder {
    pub(super) fn actuator(&mut self, el: &Element) -> Result<(), SceneError> {
        if el.name == "plugin" {
            return Err(self.err(
                el,
                format!("an actuator computed by an engine plugin ({}) is not supported by SCM: give a <position>, <velocity> or <general> actuator its gains instead", el.attr("plugin").or(el.attr("instance")).unwrap_or("unnamed")),
            ));
        }
        if el.attr("body").is_some() {
            return Err(self.err(
                el,
                "body transmissions (adhesion) are not supported by SCM: drive a joint (joint=\"NAME\"), a tendon (tendon=\"NAME\") or a site (site=\"NAME\")",
            ));
        }
        if el.attr("refsite").is_some() {
            return Err(self.err(
                el,
                "refsite (a site transmission measured in another site's frame, MuJoCo's Cartesian control) is not supported by SCM yet: drive the site alone (its force along its own axes) or the joints",
            ));
        }
        // The defaults gave every shortcut its parameters in the attributes read below
        // (`super::actuator_defaults`): a position has kp and either kv or dampratio.
        if el.name == "position" && el.attr("timeconst").is_some() {
            return Err(self.err(
                el,
                "timeconst gives a position actuator activation dynamics (MuJoCo's filterexact), which SCM's actuators do not have: remove it (the force follows the control at once)",
            ));
        }
        self.check_attrs(
            el,
            &[
                "name",
                "joint",
                "tendon",
                "site",
                "gear",
                "kp",
                "kv",
                "dampratio",
                "inheritrange",
                "ctrlrange",
                "ctrllimited",
                "forcerange",
                "forcelimited",
                "dyntype",
                "gaintype",
                "biastype",
                "dynprm",
                "gainprm",
                "biasprm",
            ],
        )?;
        let forcerange = match self.limited(el, "forcelimited", "forcerange")? {
            Some(r) if r.0 > r.1 => return Err(self.err(el, "forcerange is reversed")),
            r => r,
        };
        let target = match (el.attr("joint"), el.attr("tendon"), el.attr("site")) {
            (None, None, Some(sname)) => {
                let (body, pose) = match self.sites.get(sname) {
                    Some(Some(s)) => *s,
                    Some(None) => return Err(self.err(el, format!("site '{sname}' is placed by fromto, which SCM does not read for sites: give it pos (and quat) instead"))),
                    None => return Err(self.err(el, format!("no site named '{sname}'"))),
                };
                // MuJoCo's gear is 6 numbers for a site (default 1 0 0 0 0 0; missing ones 0).
                let mut gear = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
                if let Some(s) = el.attr("gear") {
                    match parse_floats(s) {
                        Some(v) if !v.is_empty() && v.len() <= 6 => {
                            gear = [0.0; 6];
                            gear[..v.len()].copy_from_slice(&v);
                        }
                        _ => return Err(self.err(el, format!("gear=\"{s}\": expected 1 to 6 numbers"))),
                    }
                }
                self.site_transmissions.push(crate::model::SiteTransmission {
                    name: sname.to_string(),
                    body,
                    pos: pose.translation.vector,
                    rotation: *pose.rotation.to_rotation_matrix().matrix(),
                    gear,
                });
                Transmission::Site(self.site_transmissions.len() - 1)
            }
            (Some(jname), None, None) => {
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
                Transmission::Joint(joint)
            }
            (None, Some(tname), None) => {
                let fixed = self.tendons.iter().position(|t| t.name == tname);
                let spatial = (self.spatial_tendons.iter()).position(|(t, _)| t.name == tname);
                match (fixed, spatial) {
                    (Some(t), _) => Transmission::Tendon(t),
                    (None, Some(t)) => Transmission::Spatial(t),
                    (None, None) => return Err(self.err(el, format!("no tendon named '{tname}'"))),
                }
            }
            _ => {
                return Err(self.err(
                    el,
                    "an actuator drives one joint (joint=\"NAME\"), one tendon (tendon=\"NAME\") or one site (site=\"NAME\")",
                ))
            }
        };
        let gear = match el.attr("gear") {
            // A site's gear is its transmission's 6-vector.
            _ if matches!(target, Transmission::Site(_)) => 1.0,
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
            // MuJoCo's damper: an affine gain on the velocity, `force = -kv L̇ u`, with a
            // control range that must be given and not negative.
            "damper" => {
                // MuJoCo always limits a damper's control by its ctrlrange, whatever
                // ctrllimited and autolimits say.
                match self.floats(el, "ctrlrange", 2)?.map(|r| (r[0], r[1])) {
                    Some((lo, _)) if lo < 0.0 => {
                        return Err(self.err(el, "a damper's ctrlrange cannot be negative (MuJoCo refuses it too)"))
                    }
                    Some(_) => {}
                    None => {
                        return Err(self.err(el, "a damper needs a ctrlrange (MuJoCo refuses it without): give ctrlrange=\"0 1\", say"))
                    }
                }
                ActuatorKind::General {
                    gain: [0.0, 0.0, -gain("kv", 0.0)?],
                    bias: [0.0; 3],
                }
            }
            "general" => self.general(el)?,
            _ => {
                return Err(self.err(
                    el,
                    "unsupported actuator: use motor, position, velocity, damper or general",
                ))
            }
        };
        let written = if el.name == "damper" {
            self.floats(el, "ctrlrange", 2)?.map(|r| (r[0], r[1]))
        } else if let Some(r) = self.float(el, "inheritrange")?.filter(|&r| r > 0.0) {
            // MuJoCo's inheritrange: the control range around the middle of the target's
            // range, r times its half-width (the defaults passed it over where the element
            // writes its own ctrlrange).
            let range = match target {
                Transmission::Joint(j) => self.limits[j].as_ref().map(|(lo, hi, _)| (*lo, *hi)),
                Transmission::Tendon(t) => self.tendons[t].range,
                Transmission::Spatial(t) => self.spatial_tendons[t].0.range,
                Transmission::Site(_) => None,
            };
            let Some((lo, hi)) = range else {
                return Err(self.err(el, "inheritrange needs the range of the joint or tendon it drives (a limited one): give that range, or a ctrlrange"));
            };
            let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
            Some((mid - r * half, mid + r * half))
        } else {
            self.limited(el, "ctrllimited", "ctrlrange")?
        };
        let ctrlrange = match written {
            Some(r) if r.0 > r.1 => return Err(self.err(el, "ctrlrange is reversed")),
            Some(_) if !self.flags.clampctrl => None,
            r => r,
        };
        let name = match Self::given_name(el) {
            Some(n) => n,
            None => self
                .names
                .make("actuator", format!("actuator{}", self.actuators.len())),
        };
        self.dampratios
            .push(dampratio(&kind, el, self.float(el, "dampratio")?));
        self.actuators.push(Actuator {
            name,
            kind,
            target,
            gear,
            ctrlrange,
            forcerange,
        });
        if el.name == "general" && el.attr("dynprm").is_some() {
            self.unused(
                el,
                "dynprm: MuJoCo reads it only for an activation (dyntype), which SCM's actuators do not have",
            );
        }
        Ok(())
    }

    /// A `<general>` actuator without activation: fixed or affine gain and bias.
    fn general(&self, el: &Element) -> Result<ActuatorKind, SceneError> {
        if let Some(d) = el.attr("dyntype").filter(|d| *d != "none") {
            return Err(self.err(
                el,
                format!("dyntype=\"{d}\": SCM's actuators have no activation state: use dyntype=\"none\" (the force follows the control at once)"),
            ));
        }
        // MuJoCo pads the parameter vectors with zeros (gainprm with "1 0 0 ...").
        let params = |key: &str, default: [f64; 3]| -> Result<[f64; 3], SceneError> {
            match el.attr(key) {
                None => Ok(default),
                Some(s) => match parse_floats(s) {
                    Some(v) if v.len() <= 10 => {
                        let mut out = [0.0; 3];
                        for (o, x) in out.iter_mut().zip(&v) {
                            *o = *x;
                        }
                        Ok(out)
                    }
                    _ => Err(self.err(el, format!("{key}: expected at most 10 finite numbers"))),
                },
            }
        };
        let mut gain = params("gainprm", [1.0, 0.0, 0.0])?;
        let mut bias = params("biasprm", [0.0; 3])?;
        match el.attr("gaintype").unwrap_or("fixed") {
            "fixed" => gain = [gain[0], 0.0, 0.0],
            "affine" => {}
            g => {
                return Err(self.err(
                    el,
                    format!("gaintype=\"{g}\" is not supported by SCM: use fixed or affine"),
                ))
            }
        }
        match el.attr("biastype").unwrap_or("none") {
            "none" => bias = [0.0; 3],
            "affine" => {}
            b => {
                return Err(self.err(
                    el,
                    format!("biastype=\"{b}\" is not supported by SCM: use none or affine"),
                ))
            }
        }
        Ok(ActuatorKind::General { gain, bias })
    }

    /// A range that applies as MuJoCo's `limited` attribute (true, false, or auto: given
    /// with `autolimits`) says.
    pub(super) fn limited(
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

    /// A tendon: `<fixed>` (its joints and coefficients) or `<spatial>` (its path through sites
    /// and pulleys, [`Builder::spatial_path`]), each with its spring (with MuJoCo's
    /// spring-length deadband), damper, dry friction and limits. Tendon armature is refused.
    pub(super) fn tendon(&mut self, el: &Element) -> Result<(), SceneError> {
        let spatial = match el.name.as_str() {
            "fixed" => false,
            "spatial" => true,
            _ => return Err(self.err(el, "a <tendon> holds <fixed> and <spatial> tendons")),
        };
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
                "solreflimit",
            ],
        )?;
        if spatial && self.float(el, "width")?.is_some_and(|w| w <= 0.0) {
            // MuJoCo's compiler refuses it (its drawn width), so a file with it is not valid.
            return Err(self.err(el, "width: a spatial tendon's width must be positive"));
        }
        if self.float(el, "armature")?.is_some_and(|v| v != 0.0) {
            return Err(self.err(el, "tendon armature is not supported by SCM yet: put the armature on the tendon's joints"));
        }
        let scalar = |key: &str| -> Result<f64, SceneError> {
            match el.attr(key).map(parse_floats) {
                None => Ok(0.0),
                Some(Some(v)) if v.len() == 1 && v[0] >= 0.0 => Ok(v[0]),
                Some(_) => Err(self.err(el, format!("{key}: expected one non-negative number (SCM has no polynomial tendon springs or dampers)"))),
            }
        };
        let (stiffness, damping, frictionloss) = (
            scalar("stiffness")?,
            scalar("damping")?,
            scalar("frictionloss")?,
        );
        // MuJoCo's springlength: one length, or a deadband "lo hi"; "-1 -1" (the default) is
        // the length with every joint at its springref.
        let spring_length = match el.attr("springlength").map(parse_floats) {
            None => None,
            Some(Some(v)) if v.len() == 1 => (v[0] != -1.0).then_some((v[0], v[0])),
            Some(Some(v)) if v.len() == 2 && v[0] <= v[1] => {
                (v != [-1.0, -1.0]).then_some((v[0], v[1]))
            }
            Some(_) => {
                return Err(self.err(
                    el,
                    "springlength: expected one length or an increasing pair",
                ))
            }
        };
        let range = match self.limited(el, "limited", "range")? {
            // MuJoCo's compiler refuses an empty range too ("invalid limits in tendon").
            Some(r) if r.0 >= r.1 => {
                return Err(self.err(
                    el,
                    "range: a limited tendon's range must be increasing (lo < hi)",
                ))
            }
            r => r,
        };
        let solref = self
            .floats(el, "solreflimit", 2)?
            .unwrap_or(vec![0.02, 1.0]);
        let name = match Self::given_name(el) {
            Some(n) => n,
            None => self.names.make(
                "tendon",
                format!("tendon{}", self.tendons.len() + self.spatial_tendons.len()),
            ),
        };
        let spec = TendonSpec {
            name,
            joints: vec![],
            stiffness,
            spring_length,
            damping,
            frictionloss,
            range,
            solreflimit: [solref[0], solref[1]],
            place: Place::of(el),
        };
        if spatial {
            let path = self.spatial_path(el)?;
            self.spatial_tendons.push((spec, path));
            return Ok(());
        }
        let mut joints = Vec::new();
        for j in &el.children {
            if j.name != "joint" {
                return Err(self.err(j, "a fixed tendon holds <joint> elements"));
            }
            self.check_attrs(j, &["joint", "coef"])?;
            let name = j
                .attr("joint")
                .ok_or_else(|| self.err(j, "joint=\"NAME\" is required"))?;
            let index = self
                .joints
                .iter()
                .position(|x| x.name == name)
                .ok_or_else(|| self.err(j, format!("no joint named '{name}'")))?;
            if !matches!(self.joints[index].kind, JointKind::Slide | JointKind::Hinge) {
                return Err(self.err(
                    j,
                    format!(
                        "joint '{name}' is not a slide or hinge joint: a fixed tendon's joints are"
                    ),
                ));
            }
            // MuJoCo requires the coefficient (it has no default): so does SCM.
            let coef = self.float(j, "coef")?.ok_or_else(|| {
                self.err(j, "coef is required (the joint's coefficient in the tendon's length; MuJoCo has no default for it)")
            })?;
            joints.push((index, coef));
        }
        if joints.is_empty() {
            return Err(self.err(el, "a fixed tendon needs at least one <joint>"));
        }
        self.tendons.push(TendonSpec { joints, ..spec });
        Ok(())
    }

    /// The error for a tendon name that names no fixed tendon: a spatial tendon's (`what` it,
    /// an equality of it, is not supported yet) or none.
    fn no_fixed_tendon(&self, el: &Element, name: &str, what: &str) -> SceneError {
        if self.spatial_tendons.iter().any(|(t, _)| t.name == name) {
            self.err(el, format!("tendon '{name}' is a spatial tendon: {what} a spatial tendon is not supported by SCM yet (its moment arms change with the configuration); use a fixed tendon"))
        } else {
            self.err(el, format!("no tendon named '{name}'"))
        }
    }

    /// A spatial tendon's path: `<site>` and `<pulley divisor>` elements, checked as MuJoCo's
    /// compiler checks them (at least two; a pulley neither first after a pulley nor last; a
    /// site with a neighbour that is not a pulley; a site not repeated next to itself), made
    /// into the straight segments between consecutive sites. Wrapping around a `<geom>` is
    /// refused.
    fn spatial_path(&mut self, el: &Element) -> Result<Vec<SegmentSpec>, SceneError> {
        enum Item {
            Site(String, usize, Vector3<f64>),
            Pulley(f64),
        }
        let mut path = Vec::new();
        for (i, x) in el.children.iter().enumerate() {
            match x.name.as_str() {
                "site" => {
                    self.check_attrs(x, &["site"])?;
                    let name = x
                        .attr("site")
                        .ok_or_else(|| self.err(x, "site=\"NAME\" is required"))?;
                    let (body, pose) = match self.sites.get(name) {
                        Some(Some(s)) => *s,
                        Some(None) => return Err(self.err(x, format!("site '{name}' is placed by fromto, which SCM does not read for sites: give it pos (and quat) instead"))),
                        None => return Err(self.err(x, format!("no site named '{name}'"))),
                    };
                    path.push(Item::Site(name.to_string(), body, pose.translation.vector));
                }
                "pulley" => {
                    self.check_attrs(x, &["divisor"])?;
                    let divisor = self
                        .float(x, "divisor")?
                        .ok_or_else(|| self.err(x, "divisor is required"))?;
                    if divisor <= 0.0 {
                        return Err(self.err(x, "divisor: a pulley needs a positive divisor"));
                    }
                    if matches!(path.last(), Some(Item::Pulley(_))) {
                        return Err(self.err(x, "two consecutive pulleys in a tendon's path"));
                    }
                    if i + 1 == el.children.len() {
                        return Err(self.err(x, "a tendon's path cannot end with a pulley"));
                    }
                    path.push(Item::Pulley(divisor));
                }
                "geom" => return Err(self.err(x, "wrapping a spatial tendon around a geom is not supported by SCM yet: route the tendon through sites instead (add sites where it would leave and meet the geom)")),
                _ => return Err(self.err(x, "a spatial tendon's path holds <site>, <geom> and <pulley> elements")),
            }
        }
        if path.len() < 2 {
            return Err(self.err(el, "a spatial tendon's path needs at least two objects"));
        }
        let pulley = |k: Option<&Item>| matches!(k, None | Some(Item::Pulley(_)));
        for (i, item) in path.iter().enumerate() {
            let Item::Site(name, ..) = item else { continue };
            let before = i.checked_sub(1).and_then(|k| path.get(k));
            if pulley(before) && pulley(path.get(i + 1)) {
                return Err(self.err(
                    &el.children[i],
                    format!("site '{name}' needs a neighbour in the path that is not a pulley"),
                ));
            }
            if let Some(Item::Site(next, ..)) = path.get(i + 1) {
                if next == name {
                    return Err(self.err(
                        &el.children[i + 1],
                        format!("site '{name}' is repeated in the path"),
                    ));
                }
            }
        }
        let mut scale = 1.0;
        let mut segments = Vec::new();
        for pair in path.windows(2) {
            match pair {
                [Item::Pulley(d), _] => scale = 1.0 / d,
                [Item::Site(_, b0, p0), Item::Site(_, b1, p1)] => segments.push(SegmentSpec {
                    from: (*b0, *p0),
                    to: (*b1, *p1),
                    scale,
                }),
                _ => {}
            }
        }
        Ok(segments)
    }

    /// An `<equality>` element: `joint` and `tendon` couplings, `connect` and `weld` become
    /// springs and dampers ([`crate::dynamics::equality`]); flex equalities are refused.
    pub(super) fn equality(&mut self, el: &Element) -> Result<(), SceneError> {
        let tendons = match el.name.as_str() {
            "joint" => false,
            "tendon" => true,
            "connect" | "weld" => return self.connect(el),
            _ => return Err(self.err(el, "unsupported equality constraint: SCM supports <connect>, <weld>, <joint> and <tendon> equalities (or switch equality constraints off with <option><flag equality=\"disable\"/></option>)")),
        };
        let (key1, key2) = if tendons {
            ("tendon1", "tendon2")
        } else {
            ("joint1", "joint2")
        };
        self.check_attrs(el, &["name", key1, key2, "polycoef", "solref", "active"])?;
        // Read in full even when inactive: MuJoCo refuses an inactive constraint that is wrong.
        let active = self.equality_active(el)?;
        let find = |key: &str| -> Result<Option<usize>, SceneError> {
            let Some(name) = el.attr(key) else {
                return Ok(None);
            };
            let found = if tendons {
                self.tendons.iter().position(|t| t.name == name)
            } else {
                self.joints.iter().position(|j| {
                    j.name == name && matches!(j.kind, JointKind::Slide | JointKind::Hinge)
                })
            };
            if tendons && found.is_none() {
                return Err(self.no_fixed_tendon(el, name, "an equality of"));
            }
            found.map(Some).ok_or_else(|| {
                let what = if tendons {
                    "fixed tendon"
                } else {
                    "slide or hinge joint"
                };
                self.err(el, format!("{key}: no {what} named '{name}'"))
            })
        };
        let first = find(key1)?.ok_or_else(|| self.err(el, format!("{key1} is required")))?;
        let second = find(key2)?;
        let poly = match el.attr("polycoef").map(parse_floats) {
            None => [0.0, 1.0, 0.0, 0.0, 0.0],
            Some(Some(v)) if v.len() == 5 => [v[0], v[1], v[2], v[3], v[4]],
            Some(_) => return Err(self.err(el, "polycoef: expected 5 numbers")),
        };
        let solref = self.floats(el, "solref", 2)?.unwrap_or(vec![0.02, 1.0]);
        if !active {
            return Ok(());
        }
        let name = match Self::given_name(el) {
            Some(n) => n,
            None => {
                let base = format!("equality{}", self.equalities.len() + self.connects.len());
                self.names.make("equality", base)
            }
        };
        self.equalities.push(EqualitySpec {
            name,
            tendons,
            first,
            second,
            poly,
            solref: [solref[0], solref[1]],
        });
        Ok(())
    }

    /// `<equality><connect>` and `<equality><weld>`: a point of body 1 held to body 2 (default
    /// the world) by a spring and damper, and for a weld the relative orientation too
    /// ([`crate::dynamics::equality::Connect`]). Body semantics (`body1`, and for a connect
    /// `anchor`) or site semantics (`site1`, `site2`), as MuJoCo reads them.
    fn connect(&mut self, el: &Element) -> Result<(), SceneError> {
        let weld = el.name == "weld";
        let mut allowed = vec![
            "name", "body1", "body2", "site1", "site2", "anchor", "solref", "active",
        ];
        if weld {
            allowed.extend(["relpose", "torquescale"]);
        }
        self.check_attrs(el, &allowed)?;
        // Read in full even when inactive: MuJoCo refuses an inactive constraint that is wrong.
        let active = self.equality_active(el)?;
        let anchor = self.vec3(el, "anchor")?;
        // MuJoCo's rule: bodies when body1 is given (and, for a connect, an anchor), else sites.
        let bodies = el.attr("body1").is_some() && (weld || anchor.is_some());
        let (body1, body2, anchors) = if bodies {
            if let Some(k) = ["site1", "site2"]
                .into_iter()
                .find(|k| el.attr(k).is_some())
            {
                return Err(self.err(
                    el,
                    format!("{k} beside body1: give bodies or sites, not both"),
                ));
            }
            let body = |key: &str| -> Result<Option<usize>, SceneError> {
                let Some(name) = el.attr(key) else {
                    return Ok(None);
                };
                self.bodies
                    .iter()
                    .position(|b| b.name == name)
                    .map(Some)
                    .ok_or_else(|| self.err(el, format!("{key}: no body named '{name}'")))
            };
            let relpose = match self.floats(el, "relpose", 7)? {
                // MuJoCo's default (a zero quaternion) means "as at qpos0".
                Some(p) if p[3..].iter().any(|&x| x != 0.0) => {
                    let q = nalgebra::Quaternion::new(p[3], p[4], p[5], p[6]);
                    Some(Isometry3::from_parts(
                        nalgebra::Translation3::new(p[0], p[1], p[2]),
                        UnitQuaternion::from_quaternion(q),
                    ))
                }
                _ => None,
            };
            let anchors = Anchors::Bodies {
                anchor: anchor.unwrap_or_else(Vector3::zeros),
                relpose,
            };
            (
                body("body1")?.expect("body1 given"),
                body("body2")?.unwrap_or(0),
                anchors,
            )
        } else {
            if el.attr("body1").is_some() {
                return Err(self.err(el, "a connect between bodies needs an anchor (in body 1's frame); or give site1 and site2"));
            }
            if el.attr("body2").is_some() {
                return Err(self.err(el, "body2 without body1: give body1 (and an anchor for a connect), or site1 and site2"));
            }
            let site = |key: &str| -> Result<(usize, Isometry3<f64>), SceneError> {
                let name = el.attr(key).ok_or_else(|| {
                    self.err(el, format!("{key} is required: give body1 (and an anchor for a connect), or site1 and site2"))
                })?;
                match self.sites.get(name) {
                    Some(Some(place)) => Ok(*place),
                    // An inactive constraint never needs its place.
                    Some(None) if !active => Ok((0, Isometry3::identity())),
                    Some(None) => Err(self.err(el, format!("{key}: site '{name}' is placed by fromto, which SCM does not place yet: give it pos and an orientation"))),
                    None => Err(self.err(el, format!("{key}: no site named '{name}'"))),
                }
            };
            let ((b1, s1), (b2, s2)) = (site("site1")?, site("site2")?);
            if let Some(k) = ["anchor", "relpose"]
                .into_iter()
                .find(|k| el.attr(k).is_some())
            {
                self.unused(
                    el,
                    format!("{k} (MuJoCo reads it only for an equality between bodies)"),
                );
            }
            (b1, b2, Anchors::Sites(s1, s2))
        };
        let same = body1 == body2;
        if same && bodies {
            // MuJoCo's rule: an object named twice in one constraint.
            return Err(self.err(el, "body1 and body2 are the same body: name two bodies"));
        }
        // A negative torquescale flips MuJoCo's residual and its Jacobian together: the same
        // constraint as its magnitude.
        let torquescale = self.float(el, "torquescale")?.unwrap_or(1.0).abs();
        let solref = self.floats(el, "solref", 2)?.unwrap_or(vec![0.02, 1.0]);
        if !active {
            return Ok(());
        }
        if same {
            self.unused(el, "a constraint between two sites of one body holds nothing (nor does MuJoCo's: their relative pose cannot change)");
            return Ok(());
        }
        if weld && torquescale != 0.0 && torquescale != 1.0 {
            self.warnings.push(format!(
                "{}:{}: <weld> torquescale=\"{}\": SCM holds the orientation with the time constant of solref for any torquescale other than 0; MuJoCo's soft constraint makes the rotation stiffer or softer with it",
                el.file,
                el.line,
                el.attr("torquescale").unwrap_or_default()
            ));
        }
        let name = match Self::given_name(el) {
            Some(n) => n,
            None => {
                let base = format!("equality{}", self.equalities.len() + self.connects.len());
                self.names.make("equality", base)
            }
        };
        self.connects.push(ConnectSpec {
            name,
            body1,
            body2,
            anchors,
            solref: [solref[0], solref[1]],
            weld: weld.then_some(torquescale),
        });
        Ok(())
    }

    /// An equality's `active`: `false` is listed as unused (SCM cannot switch a constraint on
    /// during a run) and the constraint left out.
    fn equality_active(&mut self, el: &Element) -> Result<bool, SceneError> {
        match el.attr("active") {
            None | Some("true") => Ok(true),
            Some("false") => {
                self.unused(el, "inactive equality constraint (active=\"false\"): SCM has no way to switch it on");
                Ok(false)
            }
            Some(v) => Err(self.err(el, format!("active=\"{v}\": expected true or false"))),
        }
    }

    pub(super) fn contact(&mut self, el: &Element) -> Result<(), SceneError> {
        for c in &el.children {
            match c.name.as_str() {
                "pair" => {
                    self.check_attrs(
                        c,
                        &[
                            "name", "geom1", "geom2", "friction", "condim", "solref", "solimp",
                        ],
                    )?;
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
                    let softness = self.softness(c, contact::Softness::default())?;
                    self.explicit_pairs.push(ExplicitPair {
                        geoms: [g1.into(), g2.into()],
                        friction,
                        softness,
                        line: c.line,
                    });
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
}

/// The damping ratio an actuator's `kv` is to be set from once the tree is built
/// (`apply_dampratios`): a position's `dampratio`, or, as MuJoCo reads any actuator whose bias
/// is a position servo's (`biasprm[1] = -gainprm[0]`), a positive `biasprm[2]`.
fn dampratio(kind: &ActuatorKind, el: &Element, written: Option<f64>) -> Option<(f64, Place)> {
    let z = match kind {
        ActuatorKind::Position { .. } => written?,
        ActuatorKind::General { gain, bias } if gain[0] == -bias[1] && bias[2] > 0.0 => bias[2],
        _ => return None,
    };
    Some((z, Place::of(el)))
}
