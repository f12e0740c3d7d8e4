//! `scm check`: a scene's bodies, point clouds, pairs, warnings, what SCM leaves unused and
//! every refusal, failing exactly where `scm pack` would refuse.

use super::Failure;
use std::io::Write;
use std::path::Path;

/// How many times its mesh's volume a hull a geom collides by may enclose before `scm check`
/// warns that it fills concave parts.
const HULL_WARNING: f64 = 2.0;

pub(super) fn check(path: &Path, w: &mut dyn Write) -> Result<(), Failure> {
    // Everything `scm pack` would refuse, all at once, before the colliders are built.
    let compiled = scm::scene::compile(path).map_err(|e| e.to_string())?;
    if !compiled.refused.is_empty() {
        for warning in &compiled.warnings {
            say!(w, "warning: {warning}");
        }
        for u in &compiled.unused {
            say!(w, "unused: {u}");
        }
        for e in &compiled.refused {
            say!(w, "refused: {e}");
        }
        return Err(format!(
            "{} refusal(s) in {}: scm pack would refuse this scene",
            compiled.refused.len(),
            path.display()
        )
        .into());
    }
    let sc = scm::scene::load(path).map_err(|e| e.to_string())?;
    let m = &sc.model;
    say!(
        w,
        "scene {} ({}): {} bodies, {} joints ({} positions, {} velocities), {} actuators",
        m.name,
        path.display(),
        m.tree.bodies.len() - 1,
        m.tree.joints.len(),
        m.tree.nq,
        m.tree.nv,
        m.actuators.len()
    );
    say!(
        w,
        "integrator {}, internal step {} s",
        m.integrator.name(),
        m.timestep
    );
    // The pruning tolerance, where the scene sets one (every cloud carries the scene's).
    if let Some(t) = m
        .prune_tolerance()
        .filter(|&t| t != scm::scalar::PRUNE_TOLERANCE)
    {
        say!(
            w,
            "pruning tolerance {t:e} (scm_prune_tolerance; the default is {:e}): softmax terms and point forces below it relative to the largest are skipped",
            scm::scalar::PRUNE_TOLERANCE
        );
    }
    let mut hull_warnings = Vec::new();
    for a in &sc.meshes {
        // A mesh whose surface is not closed is used by its convex hull (listed with the
        // warnings), or by no geom (its problem is listed with the geoms left out).
        let (mesh, what) = match (&a.mesh, &a.hull) {
            (Some(mesh), _) => (mesh, ""),
            (None, Some(hull)) if a.used => (hull, "not a closed surface, its convex hull: "),
            _ => {
                say!(
                    w,
                    "mesh {} ({}): not a closed surface, used by no geom SCM keeps",
                    a.name,
                    a.source()
                );
                continue;
            }
        };
        let mp = mesh.mass_properties();
        // A closed mesh's hull, where a geom collides by it (`scm_mesh_collision`).
        let by_hull = (sc.geoms.iter()).any(|g| g.by_hull && g.mesh.as_ref() == Some(&a.name));
        let hull = match (&a.mesh, &a.hull) {
            (Some(_), Some(h)) if by_hull => {
                let volume = h.mass_properties().volume;
                // A hull far larger than its mesh fills concave parts that other bodies may sit
                // in (as MuJoCo's does): worth a look, not an error.
                if volume > HULL_WARNING * mp.volume {
                    hull_warnings.push(format!("mesh {}: its convex hull, which MuJoCo and SCM collide by, encloses {:.1} times the mesh's volume: what sits in its concave parts touches the hull (split the mesh into convex parts, or set scm_mesh_collision to 'surface' to collide by the mesh itself)", a.name, volume / mp.volume));
                }
                format!(
                    "; collides by its convex hull, as in MuJoCo: {} vertices, {} triangles, volume {volume:.4e} m³",
                    h.vertices.len(),
                    h.triangles.len(),
                )
            }
            _ => String::new(),
        };
        say!(
            w,
            "mesh {} ({}): {what}{} vertices, {} triangles, volume {:.4e} m³{hull}{}",
            a.name,
            a.source(),
            mesh.vertices.len(),
            mesh.triangles.len(),
            mp.volume,
            if a.used { "" } else { " (unused)" }
        );
    }
    // What the clouds' own measures flag: not refusals (`scm pack` and the FMU take such a
    // cloud), warnings that a spacing or a mesh may want a look.
    let mut cloud_warnings = hull_warnings;
    // The union's volume by geoms (an estimate on a 128³ grid where it is not exact): the
    // copies of one body (a replicate's) are measured once.
    type Parts = Vec<(scm::geometry::Shape, nalgebra::Isometry3<f64>)>;
    let mut volumes: Vec<(Parts, (f64, bool))> = Vec::new();
    for (b, body) in m.tree.bodies.iter().enumerate() {
        match &m.colliders[b] {
            None => say!(w, "body {}: no collider", body.name),
            Some(scm::collision::Collider::HalfSpace { normal, .. }) => say!(
                w,
                "body {}: plane (exact half-space), normal {:?}",
                body.name,
                normal.as_slice()
            ),
            Some(scm::collision::Collider::Aopc(s)) => {
                let parts: Vec<_> = sc
                    .geoms
                    .iter()
                    .filter(|g| g.body == b)
                    // The colliding geoms (those given a spacing): the others are not sampled.
                    .filter(|g| g.spacing.is_some())
                    .filter_map(|g| g.shape.clone().map(|s| (s, g.pose)))
                    .collect();
                let spacings = sc
                    .geoms
                    .iter()
                    .filter(|g| g.body == b)
                    .filter_map(|g| {
                        g.spacing.map(|h| {
                            let points =
                                g.points.map_or(String::new(), |n| format!(", {n} points"));
                            format!(
                                "{} {} [{}]{points}",
                                g.name,
                                scm::scene::spacing_text(&h),
                                g.spacing_reason
                            )
                        })
                    })
                    .collect::<Vec<_>>()
                    .join("; ");
                let (exact, is_exact) = match volumes.iter().find(|(p, _)| *p == parts) {
                    Some((_, v)) => *v,
                    None => {
                        let v = scm::geometry::union::union_volume(&parts);
                        volumes.push((parts.clone(), v));
                        v
                    }
                };
                let closure = s.closure_defect().norm();
                let volume = s.enclosed_volume();
                say!(
                    w,
                    "body {}: {} geom(s) (sampled at: {spacings}), {} points, {} quads, {} vertices, mean spacing {:.4} m, |Σ n·area| = {:.2e} m², enclosed volume {:.4e} m³ ({} {:.4e} m³, {:+.2} %)",
                    body.name,
                    parts.len(),
                    s.len(),
                    s.faces.len(),
                    s.vertices.len(),
                    s.spacing(),
                    closure,
                    volume,
                    if is_exact { "exact" } else { "estimated" },
                    exact,
                    100.0 * (volume - exact) / exact
                );
                // How each mesh geom's triangles became its points.
                for g in sc.geoms.iter().filter(|g| g.body == b) {
                    let (Some(mesh), Some(h)) =
                        (g.shape.as_ref().and_then(|s| s.mesh()), &g.spacing)
                    else {
                        continue;
                    };
                    if let Some(scm::geometry::Shape::Implicit { .. }) = &g.shape {
                        say!(w, "  geom {}: its points facing more than 10° from the distance function's normal put on its zero level, with that normal", g.name);
                    }
                    let uniform = h.coarse.min();
                    // In patches (`TriMesh::sample_patches`) or triangle by triangle
                    // (`TriMesh::sample`: an implicit shape's mesh, a height field's, or any
                    // where the scene asks).
                    let how = match (&g.shape, mesh.sampling) {
                        (Some(scm::geometry::Shape::Implicit { .. }), _)
                        | (_, scm::geometry::mesh::MeshSampling::Triangles) => "sampled at",
                        _ => "sampled in patches of about",
                    };
                    // A mesh collides by its convex hull, as in MuJoCo, unless the scene asks
                    // for its surface (`scm_mesh_collision`).
                    let whose = if g.by_hull {
                        "its mesh's convex hull's"
                    } else {
                        "its mesh's"
                    };
                    match mesh.simplified(uniform) {
                        Some(simple) => say!(
                    w,
                            "  geom {}: {whose} {} triangles simplified to {} within {:.2} mm of that surface (estimate {:.2} mm{}), then {how} {uniform} m",
                            g.name,
                            mesh.triangles.len(),
                            simple.mesh.triangles.len(),
                            simple.tolerance * 1e3,
                            simple.error * 1e3,
                            match simple.folds {
                                0 => String::new(),
                                n => format!("; {n} triangle(s) folded inward dropped"),
                            } + &match simple.flat {
                                0 => String::new(),
                                n => format!("; {n} triangle(s) of no area dropped"),
                            }
                        ),
                        None => say!(
                    w,
                            "  geom {}: {whose} own {} triangles {how} {uniform} m (no simplification within {:.2} mm, nor within a tolerance halved {} times, keeps a closed surface with fewer triangles and the volume to {} %)",
                            g.name,
                            mesh.triangles.len(),
                            scm::geometry::mesh::SIMPLIFY_TOLERANCE * uniform * 1e3,
                            scm::geometry::mesh::SIMPLIFY_TRIES - 1,
                            scm::geometry::mesh::SIMPLIFY_VOLUME * 100.0
                        ),
                    }
                }
                // The faces of a closed surface have Σ n·area = 0 (to rounding for one geom; for
                // a union, the faces its geoms cut are measured on a 16×16 grid, within a few
                // 1e-4 of the body's area); the AOPC's volume is that of its quads (chords of
                // curved surfaces), within a few per mille of the shape's at a sensible spacing.
                let area: f64 = s.areas.iter().sum();
                if closure > 1e-3 * area {
                    cloud_warnings.push(format!(
                        "body {}: the surface is not closed (|Σ n·area| = {closure:.2e} m², {:.2} % of its area): a spacing too coarse for its geoms (set a smaller scm_spacing, or scm_spacing:GEOM for the small ones), or interior or missing faces",
                        body.name,
                        100.0 * closure / area
                    ));
                }
                let allowed = if is_exact { 0.02 } else { 0.05 };
                if (volume - exact).abs() > allowed * exact {
                    cloud_warnings.push(format!("body {}: enclosed volume {volume:.4e} m³ differs from the geoms' {exact:.4e} m³ by more than {} %: interior or missing faces, or a spacing too coarse for the shape", body.name, allowed * 100.0));
                }
            }
        }
    }
    for (k, p) in m.pairs.iter().enumerate() {
        let friction = p
            .friction
            .map_or("scm_friction".to_string(), |mu| format!("{mu}"));
        let law = match sc.pair_laws.get(k).copied().flatten() {
            Some(l) => format!(
                "stiffness {:.4e} N/m, dissipation velocity {:.4e} m/s, {} (solref {:?}, solimp {:?}, effective mass {:.4e} kg{}: MuJoCo rests at {:.3} mm)",
                l.stiffness,
                l.dissipation_velocity,
                if l.dissipation_force.is_finite() {
                    format!(
                        "dissipation force {:.4e} N{}",
                        l.dissipation_force,
                        if p.hold_separation {
                            " (a separation held to a few v_d)"
                        } else {
                            ""
                        }
                    )
                } else {
                    "damping unbounded in depth (the paper's law)".to_string()
                },
                l.softness.solref,
                l.softness.solimp,
                l.mass,
                if l.cone != 1.0 {
                    format!(", its pyramidal friction cone holding {:.3} times one row's normal force", l.cone)
                } else {
                    String::new()
                },
                l.depth * 1e3
            ),
            None => "stiffness and dissipation velocity: scm_stiffness, scm_dissipation_velocity".into(),
        };
        let margin = if p.margin != 0.0 {
            format!(", margin {} m (its springs rest that far out)", p.margin)
        } else {
            String::new()
        };
        let margin = if p.adhesion > 0.0 {
            format!(
                "{margin}, adhesion {} N within {} m past the margin (it pulls)",
                p.adhesion, p.gap
            )
        } else {
            margin
        };
        // The adhesion actuators that pull the pair (a body transmission on either body).
        let pullers: Vec<&str> = (m.actuators.iter())
            .filter(
                |a| matches!(a.target, scm::model::Transmission::Body(b) if b == p.a || b == p.b),
            )
            .map(|a| a.name.as_str())
            .collect();
        let margin = if pullers.is_empty() {
            margin
        } else {
            format!(
                "{margin}, pulled by the adhesion actuator{} {} within {} m past the margin",
                if pullers.len() > 1 { "s" } else { "" },
                pullers.join(", "),
                p.gap
            )
        };
        let margin = match &p.surface {
            Some(flows) => {
                let v = |x: &nalgebra::Vector3<f64>| format!("({} {} {})", x.x, x.y, x.z);
                let text = |f: &scm::collision::Twist<f64>| {
                    format!("{} m/s + {} rad/s x r", v(&f.lin), v(&f.ang))
                };
                format!(
                    "{margin}, moving surfaces (in each body's frame) {} and {}",
                    text(&flows[0]),
                    text(&flows[1])
                )
            }
            None => margin,
        };
        let floor = match p.friction {
            _ if p.stiction_floor == 0.0 => String::new(),
            Some(mu) => format!(
                ", stiction velocity at least {:.4e} m/s (its stiction floor)",
                p.stiction_floor * mu
            ),
            None => format!(
                ", stiction velocity at least {:.4e} m/s times scm.friction (its stiction floor)",
                p.stiction_floor
            ),
        };
        // The SSDF's temperature each body's planes are read with (docs/method.md, "ε1
        // follows the spacing").
        let eps1 = if p.eps1_scale == [1.0; 2] {
            format!("ε1 {:.4e} m² (scm.eps1)", m.contact.eps1)
        } else {
            let of = |body: usize, scale: f64| {
                let name = &m.tree.bodies[body].name;
                if scale == 1.0 {
                    format!("ε1 of {name}'s planes {:.4e} m² (scm.eps1)", m.contact.eps1)
                } else {
                    format!(
                        "ε1 of {name}'s planes {:.4e} m² (scm.eps1 times {scale:.4}: its longest quad is {:.4} m, finer than {} m)",
                        m.contact.eps1 * scale,
                        scm::contact::EPS1_SPACING * scale.sqrt(),
                        scm::contact::EPS1_SPACING
                    )
                }
            };
            format!("{}, {}", of(p.a, p.eps1_scale[0]), of(p.b, p.eps1_scale[1]))
        };
        say!(
            w,
            "pair {} - {}: friction {friction}{margin}{floor}, {eps1}, {law}",
            m.tree.bodies[p.a].name,
            m.tree.bodies[p.b].name
        );
    }
    if m.contact_points > 0 {
        say!(w, "contact points: {} per pair", m.contact_points);
    }
    cloud_warnings.extend(super::misread::misread_pairs(m));
    for warning in &sc.warnings {
        say!(w, "warning: {warning}");
    }
    for u in &sc.unused {
        say!(w, "unused: {u}");
    }
    for c in &cloud_warnings {
        say!(w, "warning: {c}");
    }
    if cloud_warnings.is_empty() {
        say!(
            w,
            "nothing scm pack would refuse, no warning on the point clouds"
        );
    } else {
        say!(
            w,
            "nothing scm pack would refuse; {} warning(s) on the point clouds above",
            cloud_warnings.len()
        );
    }
    Ok(())
}
