//! Equality constraints: `joint` and `tendon` couplings, `connect` and `weld`.

use super::*;

/// A connect or weld equality as read: the two bodies, where its points are, `solref` and
/// `solimp`, and for a weld its `torquescale`.
#[derive(Clone, Debug)]
pub(super) struct ConnectSpec {
    pub(super) name: String,
    pub(super) body1: usize,
    pub(super) body2: usize,
    pub(super) anchors: Anchors,
    pub(super) softness: contact::Softness,
    /// `Some(torquescale)` for a weld, `None` for a connect.
    pub(super) weld: Option<f64>,
}

/// Where a connect's or weld's points (and a weld's orientations) are, as MuJoCo reads them.
#[derive(Clone, Debug)]
pub(super) enum Anchors {
    /// Body semantics: `anchor` in body 1's frame (connect) or body 2's (weld); the other
    /// body's point, and a weld's relative orientation, are where they are at `qpos0`, unless
    /// a weld gives `relpose` (body 1's point and the relative orientation).
    Bodies {
        anchor: Vector3<f64>,
        relpose: Option<Isometry3<f64>>,
    },
    /// Site semantics: each site's pose in its body's frame; the points are the sites, a
    /// weld's held orientation that of site 2 on site 1.
    Sites(Isometry3<f64>, Isometry3<f64>),
}

/// A joint or tendon equality as read: the objects (joint or tendon indices), MuJoCo's
/// `polycoef`, `solref` and `solimp`.
#[derive(Clone, Debug)]
pub(super) struct EqualitySpec {
    pub(super) name: String,
    /// Whether the objects are tendons (else joints).
    pub(super) tendons: bool,
    pub(super) first: usize,
    pub(super) second: Option<usize>,
    pub(super) poly: [f64; 5],
    pub(super) softness: contact::Softness,
}

impl Builder {
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
        self.check_attrs(
            el,
            &["name", key1, key2, "polycoef", "solref", "solimp", "active"],
        )?;
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
        let softness = self.softness(el, contact::Softness::default())?;
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
            softness,
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
            "name", "body1", "body2", "site1", "site2", "anchor", "solref", "solimp", "active",
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
        let softness = self.softness(el, contact::Softness::default())?;
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
            softness,
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
}
