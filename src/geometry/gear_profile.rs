//! The profile of MuJoCo's gear SDF plugin (`mujoco.sdf.gear`) in its plane, and the smooth
//! union and intersection the plugins blend their pieces with; `ImplicitShape::distance`
//! extrudes the profile along the axis.

/// The profile in the plane at `(x, y)`, `radial` from the axis, of the gear of turn `alpha`,
/// pitch `diameter`, `teeth` and bore `inner` (`ImplicitShape::Gear`): the involutes of both
/// flanks of the nearest tooth cut by the walls between teeth, smoothly cut at the tip circle
/// and smoothly joined to the root circle, less the bore (the plugin's terms).
pub(super) fn gear_profile(
    (alpha, diameter, teeth, inner): (f64, f64, f64, f64),
    x: f64,
    y: f64,
    radial: f64,
) -> f64 {
    let pitch = teeth / diameter; // teeth per metre of diameter
    let pitch_radius = diameter / 2.0;
    let tip = pitch_radius + 1.0 / pitch;
    let depth = 2.2 / pitch;
    let bore = if inner >= 0.0 {
        inner / 2.0
    } else {
        tip - depth - 0.14 * diameter
    };
    if bore > radial {
        return bore - radial;
    }
    if radial - tip > 0.2 {
        return radial - tip;
    }
    let pressure = 3.096e-5 * teeth * teeth - 6.557e-3 * teeth + 0.551;
    let base = pitch_radius * pressure.cos();
    let stride = std::f64::consts::PI / pitch / pitch_radius; // angle from tooth to tooth
    let involute = |a: f64| a.tan() - a;
    let shift = stride / 2.0 - 2.0 * involute((base / pitch_radius).acos());
    let azimuth = y.atan2(x) + alpha;
    let wrap = |a: f64| a - stride * (a / stride).floor();
    // The angle from each flank's involute start, within the nearest tooth.
    let fa = wrap(azimuth + shift / 2.0) - shift / 2.0;
    let fb = wrap(-azimuth - shift / 2.0) - shift / 2.0;
    let (mut da, mut db) = (-1e6, -1e6);
    if base < radial {
        let roll = (base / radial).acos();
        let along = (radial * radial - base * base).sqrt();
        da = along - base * (fa + roll);
        db = along - base * (fb + roll);
    }
    let walls = (fa - (stride - shift)).max(fb - (stride - shift));
    let cogs = da.max(db).max(walls);
    let cogs = smooth_intersection(radial - tip, cogs, 0.0035 * diameter);
    let cogs = smooth_union(radial - (tip - depth), cogs, base - tip + depth);
    cogs.max(bore - radial)
}

/// The plugins' smooth union of two distances, blended over `k`.
fn smooth_union(a: f64, b: f64, k: f64) -> f64 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b * (1.0 - h) + a * h - k * h * (1.0 - h)
}

/// The plugins' smooth intersection: the intersection less the smooth union of the two
/// differences.
fn smooth_intersection(a: f64, b: f64, k: f64) -> f64 {
    a.max(b).max(-smooth_union(a.max(-b), b.max(-a), k))
}
