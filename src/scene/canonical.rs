//! The canonical form of a scene's element tree, before the model is built from it:
//! defaults applied (classes and `childclass`), `<frame>`s composed into what they hold, and
//! every orientation (`quat`, `axisangle`, `euler` in the compiler's `eulerseq`, `xyaxes`,
//! `zaxis`) written as a unit `quat` in radians. After this pass the builder reads `pos`,
//! `quat` and, for geoms, `fromto` only.

use super::defaults::{Defaults, MAIN};
use super::xml::Element;
use super::SceneError;
use nalgebra::{Isometry3, Matrix3, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3};

/// The compiler settings that decide how angles are read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Angles {
    /// `angle="degree"` (MuJoCo's default) rather than radians.
    pub degrees: bool,
    /// `eulerseq`: axes as 0, 1, 2 and whether each rotates with the frame (lowercase,
    /// intrinsic) or stays fixed (uppercase, extrinsic). MuJoCo's default is `xyz`.
    pub eulerseq: [(usize, bool); 3],
}

impl Default for Angles {
    fn default() -> Self {
        Angles {
            degrees: true,
            eulerseq: [(0, true), (1, true), (2, true)],
        }
    }
}

impl Angles {
    /// Parses an `eulerseq` value: three letters of `xyzXYZ`.
    pub fn parse_eulerseq(s: &str) -> Option<[(usize, bool); 3]> {
        let v: Vec<(usize, bool)> = s
            .chars()
            .map(|c| match c {
                'x' => Some((0, true)),
                'y' => Some((1, true)),
                'z' => Some((2, true)),
                'X' => Some((0, false)),
                'Y' => Some((1, false)),
                'Z' => Some((2, false)),
                _ => None,
            })
            .collect::<Option<_>>()?;
        v.try_into().ok()
    }

    /// An angle as written, in radians.
    pub fn radians(&self, a: f64) -> f64 {
        if self.degrees {
            a.to_radians()
        } else {
            a
        }
    }
}

/// The refusal of `el` at its file and line.
pub(super) fn error(el: &Element, message: impl Into<String>) -> SceneError {
    SceneError {
        file: el.file.to_string(),
        line: el.line,
        element: el.name.clone(),
        message: message.into(),
    }
}

/// `n` finite numbers of attribute `key`, `None` when it is absent.
pub(super) fn numbers(el: &Element, key: &str, n: usize) -> Result<Option<Vec<f64>>, SceneError> {
    let Some(s) = el.attr(key) else {
        return Ok(None);
    };
    let v: Option<Vec<f64>> = s
        .split_whitespace()
        .map(|t| t.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    match v {
        Some(v) if v.len() == n => Ok(Some(v)),
        _ => Err(error(
            el,
            format!("{key}=\"{s}\": expected {n} finite number(s)"),
        )),
    }
}

/// The rotation taking the z axis to `v` by the shortest arc (MuJoCo's convention, also for
/// `fromto` and `zaxis`): about `z × v`, or about x when `v` is (anti)parallel to z.
pub fn z_to(v: &Vector3<f64>) -> UnitQuaternion<f64> {
    let v = v.normalize();
    let cross = Vector3::z().cross(&v);
    let s = cross.norm();
    let axis = if s < 1e-10 { Vector3::x() } else { cross / s };
    let angle = s.atan2(v.z);
    UnitQuaternion::from_quaternion(Quaternion::from_parts(
        (angle / 2.0).cos(),
        axis * (angle / 2.0).sin(),
    ))
}

/// The orientation an element gives, if any: at most one of `quat` (w x y z, normalized),
/// `axisangle`, `euler`, `xyaxes`, `zaxis`.
pub fn orientation(
    el: &Element,
    angles: &Angles,
) -> Result<Option<UnitQuaternion<f64>>, SceneError> {
    let given: Vec<&str> = ["quat", "axisangle", "euler", "xyaxes", "zaxis"]
        .into_iter()
        .filter(|k| el.attr(k).is_some())
        .collect();
    if given.len() > 1 {
        return Err(error(
            el,
            format!("give one orientation, not {}", given.join(" and ")),
        ));
    }
    let Some(&kind) = given.first() else {
        return Ok(None);
    };
    let q = match kind {
        "quat" => {
            let q = numbers(el, "quat", 4)?.unwrap_or_default();
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n < 1e-10 {
                return Err(error(el, "quat is zero"));
            }
            UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
        }
        "axisangle" => {
            let a = numbers(el, "axisangle", 4)?.unwrap_or_default();
            let axis = Vector3::new(a[0], a[1], a[2]);
            if axis.norm() < 1e-10 {
                return Err(error(el, "axisangle: the axis is zero"));
            }
            UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_normalize(axis),
                angles.radians(a[3]),
            )
        }
        "euler" => {
            let e = numbers(el, "euler", 3)?.unwrap_or_default();
            let mut q = UnitQuaternion::identity();
            for (k, &(axis, rotating)) in angles.eulerseq.iter().enumerate() {
                let r = UnitQuaternion::from_axis_angle(
                    &nalgebra::Unit::new_unchecked(Vector3::ith(axis, 1.0)),
                    angles.radians(e[k]),
                );
                q = if rotating { q * r } else { r * q };
            }
            q
        }
        "xyaxes" => {
            let a = numbers(el, "xyaxes", 6)?.unwrap_or_default();
            let x = Vector3::new(a[0], a[1], a[2]);
            let y = Vector3::new(a[3], a[4], a[5]);
            if x.norm() < 1e-10 {
                return Err(error(el, "xyaxes: the x axis is zero"));
            }
            let x = x.normalize();
            let y = y - x * x.dot(&y);
            if y.norm() < 1e-10 {
                return Err(error(el, "xyaxes: the y axis is parallel to the x axis"));
            }
            let y = y.normalize();
            let z = x.cross(&y);
            let m = Matrix3::from_columns(&[x, y, z]);
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
        }
        _ => {
            let z = numbers(el, "zaxis", 3)?.unwrap_or_default();
            let z = Vector3::new(z[0], z[1], z[2]);
            if z.norm() < 1e-10 {
                return Err(error(el, "zaxis is zero"));
            }
            z_to(&z)
        }
    };
    Ok(Some(q))
}

/// The pose an element gives: `pos` and its orientation.
pub fn pose(el: &Element, angles: &Angles) -> Result<Isometry3<f64>, SceneError> {
    let p = numbers(el, "pos", 3)?.unwrap_or_else(|| vec![0.0; 3]);
    Ok(Isometry3::from_parts(
        Translation3::new(p[0], p[1], p[2]),
        orientation(el, angles)?.unwrap_or_else(UnitQuaternion::identity),
    ))
}

fn fmt3(v: &Vector3<f64>) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

fn set(el: &mut Element, key: &str, value: String) {
    match el.attrs.iter_mut().find(|(k, _)| k == key) {
        Some(e) => e.1 = value,
        None => el.attrs.push((key.to_string(), value)),
    }
}

/// Writes `pose` as `pos` and `quat`, dropping the other orientation attributes.
fn write_pose(el: &mut Element, pose: &Isometry3<f64>) {
    el.attrs
        .retain(|(k, _)| !matches!(k.as_str(), "axisangle" | "euler" | "xyaxes" | "zaxis"));
    set(el, "pos", fmt3(&pose.translation.vector));
    let q = pose.rotation.quaternion();
    set(el, "quat", format!("{} {} {} {}", q.w, q.i, q.j, q.k));
}

/// Elements whose pose is `pos` plus an orientation.
fn posed(name: &str) -> bool {
    matches!(
        name,
        "body" | "geom" | "site" | "camera" | "light" | "inertial" | "frame"
    )
}

/// The mark `<attach>` leaves on the elements it brings from another model
/// (`super::attach`): they are canonical already, under that model's defaults and angles, so
/// this file's defaults must not reach them. Not a name XML can write (it holds a space).
pub(super) const ATTACHED: &str = "scm attached";

/// Whether `el` carries the [`ATTACHED`] mark; the mark is removed.
fn take_attached(el: &mut Element) -> bool {
    let before = el.attrs.len();
    el.attrs.retain(|(k, _)| k != ATTACHED);
    el.attrs.len() != before
}

/// Brings the tree under `<worldbody>` (and the actuator, tendon, contact and equality
/// sections) into canonical form.
pub fn canonicalize(
    root: &mut Element,
    defaults: &Defaults,
    angles: &Angles,
) -> Result<(), SceneError> {
    for section in root.children.iter_mut() {
        match section.name.as_str() {
            "worldbody" => {
                if section.attr("childclass").is_some() {
                    return Err(error(section, "the worldbody cannot have a childclass"));
                }
                let children = std::mem::take(&mut section.children);
                section.children =
                    body_children(children, &Isometry3::identity(), MAIN, defaults, angles)?;
            }
            "actuator" | "tendon" | "contact" => {
                for el in section.children.iter_mut() {
                    // MuJoCo gives an actuator plugin its class's actuator defaults; SCM builds
                    // the PID plugin's actuator from what is written on it alone.
                    let class = el.attr("class").unwrap_or(MAIN).to_string();
                    if el.name == "plugin" && defaults.gives_actuators(&class) {
                        return Err(error(el, format!("default class '{class}' gives actuators defaults, which MuJoCo applies to a plugin actuator too and SCM does not apply to one yet: write the attributes on this actuator and keep it out of that class")));
                    }
                    if !take_attached(el) {
                        defaults.apply(el, MAIN)?;
                    }
                }
            }
            "equality" => {
                for el in section.children.iter_mut() {
                    if !take_attached(el) {
                        defaults.apply_equality(el)?;
                    }
                }
            }
            "asset" => {
                for el in section.children.iter_mut() {
                    if !take_attached(el) && super::defaults::slot(&el.name).is_some() {
                        defaults.apply(el, MAIN)?;
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// The children of a body (or of a frame in it), with `frame` composed onto them and the
/// class `childclass` in effect.
fn body_children(
    children: Vec<Element>,
    frame: &Isometry3<f64>,
    childclass: &str,
    defaults: &Defaults,
    angles: &Angles,
) -> Result<Vec<Element>, SceneError> {
    let mut out = Vec::with_capacity(children.len());
    for mut el in children {
        let class_here = |el: &Element| -> Result<String, SceneError> {
            match el.attr("childclass") {
                Some(c) if !defaults.has(c) => Err(error(
                    el,
                    format!("childclass: no default class named '{c}'"),
                )),
                Some(c) => Ok(c.to_string()),
                None => Ok(childclass.to_string()),
            }
        };
        match el.name.as_str() {
            "frame" => {
                let inner_class = class_here(&el)?;
                for (k, _) in &el.attrs {
                    if !matches!(
                        k.as_str(),
                        "name"
                            | "childclass"
                            | "pos"
                            | "quat"
                            | "axisangle"
                            | "euler"
                            | "xyaxes"
                            | "zaxis"
                    ) {
                        return Err(error(
                            &el,
                            format!("attribute '{k}' is not a frame attribute"),
                        ));
                    }
                }
                let inner = frame * pose(&el, angles)?;
                let kids = std::mem::take(&mut el.children);
                out.extend(body_children(kids, &inner, &inner_class, defaults, angles)?);
            }
            "body" if el.attr(ATTACHED).is_some() => {
                take_attached(&mut el);
                // Brought by an `<attach>`: only its place here is composed.
                let p = frame * pose(&el, angles)?;
                write_pose(&mut el, &p);
                out.push(el);
            }
            "body" => {
                let inner_class = class_here(&el)?;
                el.attrs.retain(|(k, _)| k != "childclass");
                if el.attr("class").is_some() {
                    return Err(error(&el, "a body takes childclass, not class"));
                }
                let p = frame * pose(&el, angles)?;
                write_pose(&mut el, &p);
                let kids = std::mem::take(&mut el.children);
                el.children =
                    body_children(kids, &Isometry3::identity(), &inner_class, defaults, angles)?;
                out.push(el);
            }
            "freejoint" => out.push(el),
            _ => {
                if !take_attached(&mut el) {
                    defaults.apply(&mut el, childclass)?;
                }
                if el.name == "geom" && el.attr("fromto").is_some() {
                    if let Some(k) = ["pos", "quat", "axisangle", "euler", "xyaxes", "zaxis"]
                        .into_iter()
                        .find(|k| el.attr(k).is_some())
                    {
                        return Err(error(&el, format!("give either fromto or {k}, not both")));
                    }
                    let f = numbers(&el, "fromto", 6)?.unwrap_or_default();
                    let a = frame * nalgebra::Point3::new(f[0], f[1], f[2]);
                    let b = frame * nalgebra::Point3::new(f[3], f[4], f[5]);
                    set(
                        &mut el,
                        "fromto",
                        format!("{} {} {} {} {} {}", a.x, a.y, a.z, b.x, b.y, b.z),
                    );
                } else if posed(&el.name) {
                    let p = frame * pose(&el, angles)?;
                    write_pose(&mut el, &p);
                } else if el.name == "joint" && *frame != Isometry3::identity() {
                    let p = numbers(&el, "pos", 3)?.unwrap_or_else(|| vec![0.0; 3]);
                    let p = frame * nalgebra::Point3::new(p[0], p[1], p[2]);
                    set(&mut el, "pos", fmt3(&p.coords));
                    if let Some(a) = numbers(&el, "axis", 3)? {
                        let a = frame.rotation * Vector3::new(a[0], a[1], a[2]);
                        set(&mut el, "axis", fmt3(&a));
                    }
                }
                out.push(el);
            }
        }
    }
    Ok(out)
}

/// Rewrites the angles of the hinge and ball joints under `el` (`range`, `ref`, `springref`)
/// from the child's unit (`degrees` or radians) into the other one, which the attaching file
/// reads. (Orientations are unit quaternions already, in the child's canonical tree.)
pub(super) fn convert_angles(el: &mut Element, degrees: bool) -> Result<(), SceneError> {
    if el.name == "joint" && matches!(el.attr("type"), None | Some("hinge") | Some("ball")) {
        for key in ["range", "ref", "springref"] {
            let n = el.attr(key).map_or(0, |v| v.split_whitespace().count());
            if n == 0 {
                continue;
            }
            let v = numbers(el, key, n)?.unwrap_or_default();
            let shown: Vec<String> = v
                .iter()
                .map(|x| {
                    if degrees {
                        x.to_radians()
                    } else {
                        x.to_degrees()
                    }
                    .to_string()
                })
                .collect();
            if let Some(slot) = el.attrs.iter_mut().find(|(k, _)| k == key) {
                slot.1 = shown.join(" ");
            }
        }
    }
    for c in el.children.iter_mut() {
        convert_angles(c, degrees)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn el(attrs: &[(&str, &str)]) -> Element {
        Element {
            name: "geom".into(),
            attrs: attrs
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            children: vec![],
            line: 1,
            file: "t.xml".into(),
            text: vec![],
        }
    }

    fn angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
        a.angle_to(b)
    }

    #[test]
    fn every_orientation_form_gives_the_same_rotation() {
        let deg = Angles::default();
        // A quarter turn about z, written five ways.
        let want = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
        for attrs in [
            [("quat", "0.7071067811865476 0 0 0.7071067811865476")],
            [("axisangle", "0 0 2 90")],
            [("euler", "0 0 90")],
            [("xyaxes", "0 1 0 -1 0 0")],
        ] {
            let q = orientation(&el(&attrs), &deg).unwrap().unwrap();
            assert!(angle_between(&q, &want) < 1e-12, "{attrs:?}: {q:?}");
        }
        let zaxis = orientation(&el(&[("zaxis", "1 0 0")]), &deg)
            .unwrap()
            .unwrap();
        assert!((zaxis * Vector3::z() - Vector3::x()).norm() < 1e-12);
        let flipped = orientation(&el(&[("zaxis", "0 0 -1")]), &deg)
            .unwrap()
            .unwrap();
        assert!((flipped * Vector3::z() + Vector3::z()).norm() < 1e-12);
    }

    #[test]
    fn euler_sequences_compose_intrinsic_and_extrinsic() {
        let (a, b) = (0.3_f64, -0.7_f64);
        let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a);
        let ry = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), b);
        let rad = |seq: &str| Angles {
            degrees: false,
            eulerseq: Angles::parse_eulerseq(seq).unwrap(),
        };
        let e = el(&[("euler", "0.3 -0.7 0")]);
        let intrinsic = orientation(&e, &rad("xyz")).unwrap().unwrap();
        let extrinsic = orientation(&e, &rad("XYZ")).unwrap().unwrap();
        assert!(intrinsic.angle_to(&(rx * ry)) < 1e-12);
        assert!(extrinsic.angle_to(&(ry * rx)) < 1e-12);
        assert!(Angles::parse_eulerseq("xyw").is_none());
        assert!(Angles::parse_eulerseq("xy").is_none());
    }

    #[test]
    fn two_orientations_are_refused() {
        let e = el(&[("quat", "1 0 0 0"), ("euler", "0 0 0")]);
        let err = orientation(&e, &Angles::default()).unwrap_err();
        assert!(err.message.contains("quat and euler"), "{err}");
    }
}
