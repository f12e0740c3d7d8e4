//! Actuators and joint limits' settings.

use super::*;

/// What actuators drive beyond joints and tendons: sites (`site=`, with their gears) and
/// slider-cranks.
#[derive(Clone, Debug, Default)]
pub struct Transmissions {
    /// Site transmissions.
    pub sites: Vec<crate::model::SiteTransmission>,
    /// Slider-crank transmissions.
    pub slider_cranks: Vec<crate::model::SliderCrank>,
}

impl Builder {
    /// A slider-crank transmission (`cranksite`, `slidersite`, `cranklength`), as MuJoCo reads
    /// it: both sites, a positive rod length, and nothing else to drive.
    fn slider_crank(&mut self, el: &Element) -> Result<Option<Transmission>, SceneError> {
        let (crank, slider) =
            match (el.attr("cranksite"), el.attr("slidersite")) {
                (None, None) => {
                    if el.attr("cranklength").is_some() {
                        self.unused(
                            el,
                            "cranklength: this actuator is not a slider-crank (no cranksite)",
                        );
                    }
                    return Ok(None);
                }
                (Some(c), Some(s)) => (c, s),
                _ => return Err(self.err(
                    el,
                    "a slider-crank needs both cranksite and slidersite (MuJoCo refuses one alone)",
                )),
            };
        if ["joint", "tendon", "site"]
            .iter()
            .any(|k| el.attr(k).is_some())
        {
            return Err(self.err(el, "an actuator drives one thing: a slider-crank (cranksite, slidersite) or a joint, a tendon or a site, not both"));
        }
        let rod = match self.float(el, "cranklength")? {
            Some(r) if r > 0.0 => r,
            _ => return Err(self.err(el, "a slider-crank needs a positive cranklength, the rod's length (MuJoCo refuses it otherwise)")),
        };
        let site = |b: &Self, name: &str| {
            match b.sites.get(name) {
            Some(Some(s)) => Ok(*s),
            Some(None) => Err(b.err(el, format!("site '{name}' is placed by fromto, which SCM does not read for sites: give it pos (and quat) instead"))),
            None => Err(b.err(el, format!("no site named '{name}'"))),
        }
        };
        let (cb, cpose) = site(self, crank)?;
        let (sb, spose) = site(self, slider)?;
        self.transmissions
            .slider_cranks
            .push(crate::model::SliderCrank {
                crank: (crank.to_string(), cb, cpose.translation.vector),
                slider: (
                    slider.to_string(),
                    sb,
                    spose.translation.vector,
                    *spose.rotation.to_rotation_matrix().matrix(),
                ),
                rod,
            });
        Ok(Some(Transmission::SliderCrank(
            self.transmissions.slider_cranks.len() - 1,
        )))
    }

    /// A body transmission (`body=`), MuJoCo's adhesion's: the body alone to drive, and for an
    /// `<adhesion>` a control range that is given and not negative (MuJoCo refuses it
    /// otherwise; its control is always limited).
    fn body_transmission(&mut self, el: &Element) -> Result<Transmission, SceneError> {
        if ["joint", "tendon", "site", "cranksite"]
            .iter()
            .any(|k| el.attr(k).is_some())
        {
            return Err(self.err(el, "an actuator drives one thing: a body (body=\"NAME\", MuJoCo's adhesion) or a joint, a tendon or a site, not both"));
        }
        let name = el.attr("body").unwrap_or_default();
        let body = (self.bodies.iter())
            .position(|b| b.name == name)
            .ok_or_else(|| self.err(el, format!("no body named '{name}'")))?;
        if body == 0 {
            return Err(self.err(el, "an adhesion on the world body pulls nothing SCM can move (MuJoCo's contacts with the world are the other bodies'): name the moving body to pull"));
        }
        if el.name == "adhesion" {
            match self.floats(el, "ctrlrange", 2)? {
                Some(r) if r[0] < 0.0 || r[1] < 0.0 => {
                    return Err(self.err(el, "an adhesion's ctrlrange cannot be negative (MuJoCo refuses it too)"))
                }
                Some(_) => {}
                None => return Err(self.err(el, "an adhesion needs a ctrlrange (its control is always limited, and MuJoCo's default range 0 0 pulls with nothing): give ctrlrange=\"0 1\", say")),
            }
        }
        Ok(Transmission::Body(body))
    }

    pub(super) fn actuator(&mut self, el: &Element) -> Result<(), SceneError> {
        if el.name == "plugin" {
            let (general, integral) = self.pid_as_general(el)?;
            self.actuator(&general)?;
            if let Some(law) = integral {
                // Its step is the file's (filled in at assembly). MuJoCo refuses an actrange
                // without dyntype, so the integral has no range but its imax.
                let target = self.actuators.last().map(|a| a.target);
                if !matches!(
                    target,
                    Some(Transmission::Joint(_) | Transmission::Tendon(_))
                ) {
                    return Err(self.err(el, "a PID plugin's integral (ki) on a spatial tendon, a site or a slider-crank is not supported by SCM: its error reads the actuator's length, which SCM reads for joints and fixed tendons only; drive a joint or a fixed tendon"));
                }
                let a = self.actuators.last_mut().expect("the actuator just added");
                a.activation = Some(Activation {
                    law,
                    range: None,
                    early: false,
                });
            }
            return Ok(());
        }
        if el.attr("refsite").is_some() {
            return Err(self.err(
                el,
                "refsite (a site transmission measured in another site's frame, MuJoCo's Cartesian control) is not supported by SCM yet: drive the site alone (its force along its own axes) or the joints",
            ));
        }
        // The defaults gave every shortcut its parameters in the attributes read below
        // (`super::actuator_defaults`): a position has kp and either kv or dampratio.
        self.check_attrs(
            el,
            &[
                "name",
                "joint",
                "tendon",
                "site",
                "body",
                "gain",
                "gear",
                "kp",
                "kv",
                "dampratio",
                "inheritrange",
                "ctrlrange",
                "ctrllimited",
                "forcerange",
                "forcelimited",
                "timeconst",
                "cranksite",
                "slidersite",
                "cranklength",
                "actlimited",
                "actrange",
                "actearly",
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
        let crank = self.slider_crank(el)?;
        let target = match (crank, el.attr("joint"), el.attr("tendon"), el.attr("site")) {
            _ if el.attr("body").is_some() => self.body_transmission(el)?,
            (Some(t), ..) => t,
            (None, None, None, Some(sname)) => {
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
                self.transmissions.sites.push(crate::model::SiteTransmission {
                    name: sname.to_string(),
                    body,
                    pos: pose.translation.vector,
                    rotation: *pose.rotation.to_rotation_matrix().matrix(),
                    gear,
                });
                Transmission::Site(self.transmissions.sites.len() - 1)
            }
            (None, Some(jname), None, None) => {
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
            (None, None, Some(tname), None) => {
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
            // A site's gear is its transmission's 6-vector; MuJoCo's body transmission does
            // not read it.
            _ if matches!(target, Transmission::Site(_) | Transmission::Body(_)) => 1.0,
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
            // MuJoCo's adhesion: a fixed gain, no bias.
            "adhesion" => ActuatorKind::General {
                gain: [gain("gain", 1.0)?, 0.0, 0.0],
                bias: [0.0; 3],
            },
            _ => return Err(self.err(
                el,
                "unsupported actuator: use motor, position, velocity, damper, adhesion or general",
            )),
        };
        let written = if el.name == "damper" || el.name == "adhesion" {
            self.floats(el, "ctrlrange", 2)?.map(|r| (r[0], r[1]))
        } else if let Some(r) = self.float(el, "inheritrange")?.filter(|&r| r > 0.0) {
            // MuJoCo's inheritrange: the control range around the middle of the target's
            // range, r times its half-width (the defaults passed it over where the element
            // writes its own ctrlrange).
            let range = match target {
                Transmission::Joint(j) => self.limits[j].as_ref().map(|(lo, hi, _)| (*lo, *hi)),
                Transmission::Tendon(t) => self.tendons[t].range,
                Transmission::Spatial(t) => self.spatial_tendons[t].0.range,
                Transmission::Site(_) | Transmission::SliderCrank(_) | Transmission::Body(_) => {
                    None
                }
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
        let activation = self.activation(el)?;
        self.actuators.push(Actuator {
            name,
            kind,
            target,
            gear,
            ctrlrange,
            forcerange,
            activation,
        });
        Ok(())
    }

    /// An actuator's activation dynamics, as MuJoCo reads them: a `<general>`'s `dyntype`
    /// (`integrator`, `filter`, `filterexact`) with its time constant `dynprm[0]`, a
    /// `<position>`'s `timeconst` (a `filterexact` filter), with `actlimited`/`actrange` and
    /// `actearly`; those three noted unused on an actuator without activation, as in MuJoCo.
    fn activation(&mut self, el: &Element) -> Result<Option<Activation>, SceneError> {
        let tau = |key: &str, at: usize| -> Result<f64, SceneError> {
            let v = match el.attr(key) {
                None => 1.0,
                Some(s) => match parse_floats(s) {
                    Some(v) if v.len() > at => v[at],
                    Some(_) => 1.0,
                    None => return Err(self.err(el, format!("{key}: expected finite numbers"))),
                },
            };
            Ok(v)
        };
        let law = match (el.name.as_str(), el.attr("dyntype")) {
            ("position", _) => match self.float(el, "timeconst")? {
                Some(t) if t < 0.0 => {
                    return Err(self.err(el, format!("timeconst=\"{t}\" must not be negative")))
                }
                Some(t) if t > 0.0 => Some(ActivationLaw::FilterExact { tau: t }),
                _ => None,
            },
            ("general", None | Some("none")) => {
                if el.attr("dynprm").is_some() {
                    self.unused(el, "dynprm: MuJoCo reads it only for an activation (dyntype)");
                }
                None
            }
            ("general", Some("integrator")) => Some(ActivationLaw::Integrator),
            ("general", Some("filter")) => Some(ActivationLaw::Filter {
                tau: tau("dynprm", 0)?,
            }),
            ("general", Some("filterexact")) => Some(ActivationLaw::FilterExact {
                tau: tau("dynprm", 0)?,
            }),
            ("general", Some(d)) => {
                return Err(self.err(
                    el,
                    format!(
                        "dyntype=\"{d}\" is not supported by SCM: use none, integrator, filter or filterexact ({})",
                        match d {
                            "muscle" => "MuJoCo's muscle model, with its muscle gain and bias, is not modelled",
                            "user" => "a user callback's dynamics cannot be read from the file",
                            _ => "MuJoCo knows these four and muscle",
                        }
                    ),
                ))
            }
            _ => None,
        };
        let range = match self.limited(el, "actlimited", "actrange")? {
            Some(r) if r.0 > r.1 => return Err(self.err(el, "actrange is reversed")),
            r => r,
        };
        let early = match el.attr("actearly") {
            None | Some("false") => false,
            Some("true") => true,
            Some(v) => {
                return Err(self.err(el, format!("actearly=\"{v}\": expected true or false")))
            }
        };
        let Some(law) = law else {
            for key in ["actlimited", "actrange", "actearly"] {
                if el.attr(key).is_some() {
                    self.unused(el, format!("{key}: this actuator has no activation (MuJoCo reads it only with dynamics)"));
                }
            }
            return Ok(None);
        };
        Ok(Some(Activation { law, range, early }))
    }

    /// A `<general>` actuator's force law: fixed or affine gain and bias (its activation, if
    /// any, is [`Builder::activation`]'s).
    fn general(&self, el: &Element) -> Result<ActuatorKind, SceneError> {
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
