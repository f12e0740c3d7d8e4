//! Tendons: `<fixed>` (joints and coefficients) and `<spatial>` (a path through sites and
//! pulleys), with their springs, dampers, dry friction and limits.

use super::*;
use crate::dynamics::wrap::{Wrap, WrapShape};

/// A fixed tendon as read, before the tree gives its joints' coordinates.
#[derive(Clone, Debug)]
pub(super) struct TendonSpec {
    pub(super) name: String,
    /// `(joint index, coefficient)`.
    pub(super) joints: Vec<(usize, f64)>,
    pub(super) stiffness: f64,
    /// `springlength`, unless it is MuJoCo's default (the length with every joint at its springref).
    pub(super) spring_length: Option<(f64, f64)>,
    pub(super) damping: f64,
    pub(super) frictionloss: f64,
    /// The length's range, if limited.
    pub(super) range: Option<(f64, f64)>,
    /// `solreflimit` and `solimplimit`.
    pub(super) limit_softness: contact::Softness,
    /// Where the tendon is written.
    pub(super) place: Place,
}

/// A segment of a spatial tendon: the two sites (body, point in its frame), `1 / divisor` of
/// its pulley branch and the geom it wraps around, if any.
#[derive(Clone, Copy, Debug)]
pub(super) struct SegmentSpec {
    pub(super) from: (usize, Vector3<f64>),
    pub(super) to: (usize, Vector3<f64>),
    pub(super) scale: f64,
    pub(super) wrap: Option<Wrap>,
}

impl Builder {
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
                "solimplimit",
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
        let limit_softness = self.limit_softness_of(el)?;
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
            limit_softness,
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
    pub(super) fn no_fixed_tendon(&self, el: &Element, name: &str, what: &str) -> SceneError {
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
            Geom(Wrap),
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
                "geom" => {
                    let wrap = self.wrap_geom(x)?;
                    if !matches!(path.last(), Some(Item::Site(..))) {
                        return Err(
                            self.err(x, "a wrapping geom must follow a site in the tendon's path")
                        );
                    }
                    if !matches!(el.children.get(i + 1), Some(n) if n.name == "site") {
                        return Err(self.err(
                            x,
                            "a wrapping geom must be followed by a site in the tendon's path",
                        ));
                    }
                    path.push(Item::Geom(wrap));
                }
                _ => {
                    return Err(self.err(
                        x,
                        "a spatial tendon's path holds <site>, <geom> and <pulley> elements",
                    ))
                }
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
        for (i, pair) in path.windows(2).enumerate() {
            let segment = |to: &Item, wrap| match (&pair[0], to) {
                (Item::Site(_, b0, p0), Item::Site(_, b1, p1)) => Some(SegmentSpec {
                    from: (*b0, *p0),
                    to: (*b1, *p1),
                    scale,
                    wrap,
                }),
                _ => None,
            };
            match pair {
                [Item::Pulley(d), _] => scale = 1.0 / d,
                [Item::Site(..), Item::Geom(w)] => segments.extend(segment(&path[i + 2], Some(*w))),
                [Item::Site(..), to] => segments.extend(segment(to, None)),
                _ => {}
            }
        }
        Ok(segments)
    }

    /// A wrapping geom of a spatial tendon's path (`<geom geom sidesite>`): a sphere or a
    /// cylinder (MuJoCo wraps no other shape), with its side site.
    fn wrap_geom(&mut self, x: &Element) -> Result<Wrap, SceneError> {
        self.check_attrs(x, &["geom", "sidesite"])?;
        let name = x
            .attr("geom")
            .ok_or_else(|| self.err(x, "geom=\"NAME\" is required"))?;
        let g = (self.geoms.iter().find(|g| g.name == name))
            .ok_or_else(|| self.err(x, format!("no geom named '{name}'")))?;
        let (shape, radius) = match g.shape {
            Some(Shape::Sphere { radius }) => (WrapShape::Sphere, radius),
            Some(Shape::Cylinder { radius, .. }) => (WrapShape::Cylinder, radius),
            _ => {
                return Err(self.err(
                    x,
                    format!(
                        "geom '{name}': a tendon wraps only a sphere or a cylinder (as MuJoCo's)"
                    ),
                ))
            }
        };
        let side = match x.attr("sidesite") {
            None => None,
            Some(s) => match self.sites.get(s) {
                Some(Some((body, pose))) => Some((*body, pose.translation.vector)),
                Some(None) => return Err(self.err(x, format!("site '{s}' is placed by fromto, which SCM does not read for sites: give it pos (and quat) instead"))),
                None => return Err(self.err(x, format!("no site named '{s}'"))),
            },
        };
        // A side site outside the geom picks the side as MuJoCo's published algorithm does,
        // which MuJoCo 4.0 departs from in some poses (docs/mjcf.md, "Spatial tendons").
        let (body, pose) = (g.body, g.pose);
        let outside = side.map(|(b, p)| {
            b != body
                || pose
                    .inverse_transform_point(&nalgebra::Point3::from(p))
                    .coords
                    .norm()
                    >= radius
        });
        if outside == Some(true) {
            self.warnings.push(format!("{}:{}: <geom> tendon wrapping geom '{name}' with side site '{}' outside it{}: SCM wraps as MuJoCo's published algorithm does, and MuJoCo 4.0 wraps differently in some poses (where the side site pulls the tendon round a geom its straight path misses, and in a few where it meets it: docs/mjcf.md, \"Spatial tendons\"); with no side site, or one inside the geom, the two agree to rounding", x.file, x.line, x.attr("sidesite").unwrap_or_default(), if side.is_some_and(|(b, _)| b != body) { " (or on another body)" } else { "" }));
        }
        Ok(Wrap {
            body,
            pose,
            shape,
            radius,
            side,
        })
    }
}
