//! `<compiler>`, `<option>` with its flags, and `<custom>` (SCM's own settings): what the file
//! says about how to compile and simulate it.

use super::*;

/// How body inertias come from geoms (`<compiler inertiafromgeom>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum InertiaFromGeom {
    /// From the geoms unless the body has an `<inertial>` (MuJoCo's default).
    Auto,
    /// Always from the geoms; `<inertial>` is overridden.
    Always,
    /// Never: a body without `<inertial>` has no mass.
    Never,
}

/// `<compiler>` settings that shape the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct CompilerSettings {
    /// Joint and control ranges make a joint or control limited when `limited` is not given.
    pub(super) autolimits: bool,
    pub(super) inertia_from_geom: InertiaFromGeom,
    /// Geom groups whose geoms add mass.
    pub(super) inertia_groups: (i64, i64),
    /// Scale every mass and inertia so the bodies weigh this much in total (kg; off if <= 0).
    pub(super) total_mass: f64,
    /// Least mass of a body (kg).
    pub(super) bound_mass: f64,
    /// Least principal moment of inertia of a body (kg m²).
    pub(super) bound_inertia: f64,
    /// Mesh-fitted primitives fit the mesh's bounding box in its inertia frame (`fitaabb`),
    /// instead of its equivalent inertia box.
    pub(super) fit_aabb: bool,
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
            fit_aabb: false,
        }
    }
}

/// `<option><flag>` switches that change the physics (all on by default, as in MuJoCo).
#[derive(Clone, Copy, Debug)]
pub(super) struct Flags {
    pub(super) gravity: bool,
    pub(super) contact: bool,
    pub(super) limit: bool,
    pub(super) equality: bool,
    pub(super) frictionloss: bool,
    pub(super) spring: bool,
    pub(super) damper: bool,
    pub(super) actuation: bool,
    pub(super) filterparent: bool,
    pub(super) clampctrl: bool,
    pub(super) eulerdamp: bool,
    /// MuJoCo's `refsafe`: a constraint's time constant (contacts, limits, equalities) held at
    /// no less than twice the step.
    pub(super) refsafe: bool,
    /// MuJoCo's `override` (off by default): every contact takes `<option>`'s `o_margin`,
    /// `o_solref`, `o_solimp` and `o_friction` instead of its geoms' or pair's.
    pub(super) override_contacts: bool,
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
            refsafe: true,
            override_contacts: false,
        }
    }
}

/// Attributes that only configure MuJoCo's renderer or constraint solver (or carry user data):
/// accepted anywhere and listed as unused by SCM, with why.
pub(super) const UNUSED_ATTRIBUTES: &[(&str, &str)] = &[
    ("rgba", "renderer"),
    ("material", "renderer"),
    ("texture", "renderer"),
    ("group", "renderer groups"),
    ("width", "renderer (a tendon's drawn width)"),
    ("user", "user data"),
    (
        "margin",
        "MuJoCo's activation distance of a joint's or tendon's limit; SCM's limits act from the limit itself (a geom's or pair's margin is read: it shifts the contact)",
    ),
    (
        "gap",
        "MuJoCo's inactive contacts, listed in its mjData.contact with no force; SCM keeps no such list (read only where the contact can pull: a geom's adhesion or an adhesion actuator on one of its bodies, as the reach of the pull)",
    ),
    (
        "solref",
        "MuJoCo's constraint solver; SCM reads it on geoms, contact pairs and equalities (and solreflimit, solimplimit on joints and tendons)",
    ),
    (
        "solimp",
        "MuJoCo's constraint solver; SCM reads it on geoms, contact pairs and equalities",
    ),
    ("solmix", "MuJoCo's contact solver"),
    ("priority", "MuJoCo's contact solver"),
    ("solreffriction", "MuJoCo's constraint solver"),
    ("solimpfriction", "MuJoCo's constraint solver"),
    ("iterations", "MuJoCo's constraint solver"),
    ("ls_iterations", "MuJoCo's constraint solver"),
    ("noslip_iterations", "MuJoCo's constraint solver"),
    (
        "sleep_tolerance",
        "MuJoCo's sleeping of resting bodies, a speed setting",
    ),
    (
        "sleep",
        "MuJoCo's sleeping policy of a body, a speed setting",
    ),
    ("ccd_iterations", "MuJoCo's collision detection"),
    ("sdf_iterations", "MuJoCo's collision detection"),
    ("sdf_initpoints", "MuJoCo's collision detection"),
    ("tolerance", "MuJoCo's constraint solver"),
    ("ls_tolerance", "MuJoCo's constraint solver"),
    ("noslip_tolerance", "MuJoCo's constraint solver"),
    ("ccd_tolerance", "MuJoCo's collision detection"),
    ("jacobian", "MuJoCo's constraint solver"),
    ("solver", "MuJoCo's constraint solver"),
    ("apirate", "MuJoCo's remote API"),
    ("actuatorgroupdisable", "MuJoCo's actuator groups"),
    ("texturedir", "renderer"),
    ("inertiagrouprange", "read"),
    ("align", "renderer"),
    ("mode", "camera tracking"),
    ("target", "camera tracking"),
];

/// What to do instead, for an attribute SCM refuses, where there is a clear answer.
pub(super) fn advice(element: &str, attr: &str) -> &'static str {
    match (element, attr) {
        (_, "class") | (_, "childclass") => ": defaults should have been applied (report this)",
        (_, "cranksite") | (_, "slidersite") | (_, "cranklength") => {
            ": slider-crank transmissions are not supported; drive a joint or a fixed tendon"
        }
        ("joint", "actuatorgravcomp") => {
            ": gravity compensation through the actuators is not modelled; remove it (the bodies' gravcomp then acts as a passive force, MuJoCo's default)"
        }
        _ => "",
    }
}

impl Builder {
    /// `<compiler>`: read before the tree is made canonical (the angle unit and Euler
    /// sequence decide how orientations read).
    pub(super) fn compiler(&mut self, el: &Element) -> Result<(), SceneError> {
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
        if let Some(a) = flag("fitaabb")? {
            self.settings.fit_aabb = a;
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

    pub(super) fn option(&mut self, el: &Element) -> Result<(), SceneError> {
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
                "o_margin",
                "o_solref",
                "o_solimp",
                "o_friction",
                "cone",
                "impratio",
            ],
        )?;
        // The friction cone: its pyramid's normal is softer or stiffer than the elliptic
        // cone's with the friction coefficient, and each pair's law follows it
        // (`contact::cone_share`).
        match el.attr("cone") {
            None => {}
            Some("pyramidal") => self.cone.elliptic = false,
            Some("elliptic") => self.cone.elliptic = true,
            Some(c) => {
                return Err(self.err(el, format!("cone=\"{c}\": expected pyramidal or elliptic")))
            }
        }
        if let Some(r) = self.float(el, "impratio")? {
            self.cone.impratio = r;
        }
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
        self.contact_override(el)?;
        match el.attr("integrator") {
            None => {}
            // MuJoCo's "Euler" is semi-implicit in velocity, with joint damping implicit
            // (unless <flag eulerdamp="disable">, applied in `apply_flags`).
            Some("Euler") => self.option_integrator = Some(Integrator::DampedEuler),
            // MuJoCo's RK4 solves its constraints at every stage: the contact's damping and
            // friction implicit in velocity there, as damped RK4's stages take them.
            Some("RK4") => self.option_integrator = Some(Integrator::DampedRk4),
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
    pub(super) fn flag(&mut self, el: &Element) -> Result<(), SceneError> {
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
                "refsafe" => f.refsafe = on,
                "override" => f.override_contacts = on,
                "constraint" => {
                    // Every constraint: contacts, limits, equalities, friction loss.
                    f.contact &= on;
                    f.limit &= on;
                    f.equality &= on;
                    f.frictionloss &= on;
                }
                "passive" => return Err(self.err(el, "flag passive was MuJoCo 2's; MuJoCo 3 and 4 refuse it: use spring=\"disable\" damper=\"disable\"")),
                "warmstart" | "energy" | "sensor" | "midphase" | "island" | "nativeccd"
                | "multiccd" | "fwdinv" | "invdiscrete" | "autoreset" | "sleep" | "diagexact" | "speculative" | "ipc" => {
                    let why = format!("flag {k} (MuJoCo's solver and pipeline)");
                    self.unused(el, why);
                }
                _ => return Err(self.err(el, format!("'{k}' is not a MuJoCo flag"))),
            }
        }
        Ok(())
    }

    pub(super) fn custom(&mut self, el: &Element) -> Result<(), SceneError> {
        for n in &el.children {
            let name = n
                .attr("name")
                .ok_or_else(|| self.err(n, "missing name"))?
                .to_string();
            // MuJoCo: a numeric needs `data` or a positive `size` (zeros), a text its `data`;
            // a tuple holds `<element>` children and no data.
            let data = match (n.name.as_str(), n.attr("data")) {
                (_, Some(d)) => d,
                ("tuple", None) => "",
                ("numeric", None)
                    if n.attr("size")
                        .and_then(|s| s.trim().parse::<u32>().ok())
                        .is_some_and(|s| s > 0)
                        && !name.starts_with("scm_") =>
                {
                    ""
                }
                _ => return Err(self.err(n, "missing data")),
            };
            match n.name.as_str() {
                "numeric" => {
                    if name.starts_with("scm_") {
                        let v = parse_floats(data).filter(|v| v.len() == 1).ok_or_else(|| {
                            self.err(
                                n,
                                format!("{name}: data=\"{data}\" must be one finite number"),
                            )
                        })?;
                        self.numeric.push((name, v[0], Place::of(n)));
                    } else {
                        self.unused(n, "custom data (for the user's code; no physics reads it)");
                    }
                }
                "text" => {
                    if name.starts_with("scm_") {
                        self.text.push((name, data.to_string(), Place::of(n)));
                    } else {
                        self.unused(n, "custom data (for the user's code; no physics reads it)");
                    }
                }
                "tuple" => self.unused(n, "custom data (for the user's code; no physics reads it)"),
                _ => return Err(self.err(n, "unsupported custom element")),
            }
        }
        Ok(())
    }

    /// Applies the `<option><flag>` switches; returns what SCM refuses to simulate (features
    /// that change the physics and that SCM does not model), first in file order first.
    pub(super) fn apply_flags(&mut self) -> Vec<SceneError> {
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
}
