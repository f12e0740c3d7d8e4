//! `scm`: pack scenes into FMUs, inspect their point clouds, check and simulate them (SPEC §6).

use scm::fmi::contract::{FmiModel, VarType};
use scm::sim::Simulation;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const USAGE: &str = "usage:
  scm pack SCENE.xml -o OUT.fmu [--lib PATH/libscm.so]   build an FMU of the scene
  scm simulate SCENE.xml [--duration S] [--step S] [--integrator NAME] [-o OUT.csv]   run natively, write CSV
        (integrators: euler, semi_implicit_euler, rk4, implicit_euler, dopri5; default: the scene's)
  scm aopc SCENE.xml BODY                                print a body's AOPC as CSV (body frame)
  scm check SCENE.xml                                    report the scene's contents and problems
  scm compile SCENE.xml                                  print the compiled model as JSON (MuJoCo's conventions)";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("scm: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Value of `--flag VALUE` (or `-f VALUE`), removing both from `args`.
fn take_opt(args: &mut Vec<String>, names: &[&str]) -> Result<Option<String>, String> {
    match args.iter().position(|a| names.contains(&a.as_str())) {
        None => Ok(None),
        Some(i) if i + 1 < args.len() => {
            let v = args.remove(i + 1);
            args.remove(i);
            Ok(Some(v))
        }
        Some(i) => Err(format!("{} needs a value", args[i])),
    }
}

fn number(s: Option<String>, name: &str, default: f64) -> Result<f64, String> {
    match s {
        None => Ok(default),
        Some(s) => s
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| format!("{name} {s}: expected a positive number")),
    }
}

fn run(args: &[String]) -> Result<(), String> {
    let mut args = args.to_vec();
    if args.is_empty() || args[0] == "-h" || args[0] == "--help" {
        println!("{USAGE}");
        return Ok(());
    }
    let cmd = args.remove(0);
    match cmd.as_str() {
        "simulate" => {
            let duration = number(take_opt(&mut args, &["--duration"])?, "--duration", 1.0)?;
            let out = take_opt(&mut args, &["-o", "--output"])?;
            let comm = take_opt(&mut args, &["--step"])?;
            let integrator = take_opt(&mut args, &["--integrator"])?;
            let [scene] = positional(&args, &["SCENE.xml"])?;
            let mut sim = Simulation::from_file(Path::new(&scene)).map_err(|e| e.to_string())?;
            if let Some(name) = integrator {
                sim.model.integrator =
                    scm::integrate::Integrator::from_name(&name).ok_or_else(|| {
                        format!(
                            "--integrator {name}: known integrators are {}",
                            scm::integrate::Integrator::ALL.map(|i| i.name()).join(", ")
                        )
                    })?;
            }
            let h = number(comm, "--step", sim.model.step.max(0.01))?;
            simulate(&mut sim, duration, h, out.map(PathBuf::from))
        }
        "compile" => {
            let [scene] = positional(&args, &["SCENE.xml"])?;
            let c = scm::scene::compile(Path::new(&scene)).map_err(|e| e.to_string())?;
            let text = serde_json::to_string_pretty(&c.to_json()).map_err(|e| e.to_string())?;
            println!("{text}");
            Ok(())
        }
        "aopc" => {
            let [scene, body] = positional(&args, &["SCENE.xml", "BODY"])?;
            let sc = scm::scene::load(Path::new(&scene)).map_err(|e| e.to_string())?;
            let b = sc
                .model
                .tree
                .bodies
                .iter()
                .position(|b| b.name == body)
                .ok_or_else(|| format!("{scene}: no body named '{body}'"))?;
            let stdout = std::io::stdout();
            let mut w = stdout.lock();
            writeln!(w, "x,y,z,nx,ny,nz").map_err(|e| e.to_string())?;
            match &sc.model.colliders[b] {
                Some(scm::collision::Collider::Aopc(s)) => {
                    for (p, n) in s.points.iter().zip(&s.normals) {
                        writeln!(w, "{},{},{},{},{},{}", p.x, p.y, p.z, n.x, n.y, n.z)
                            .map_err(|e| e.to_string())?;
                    }
                }
                Some(scm::collision::Collider::HalfSpace { .. }) => {
                    return Err(format!(
                        "body '{body}' is a plane (an exact half-space, not a point cloud)"
                    ))
                }
                None => return Err(format!("body '{body}' has no collision geometry")),
            }
            Ok(())
        }
        "check" => {
            let [scene] = positional(&args, &["SCENE.xml"])?;
            check(Path::new(&scene))
        }
        "pack" => {
            let out = take_opt(&mut args, &["-o", "--output"])?.ok_or("pack needs -o OUT.fmu")?;
            let lib = take_opt(&mut args, &["--lib"])?;
            let [scene] = positional(&args, &["SCENE.xml"])?;
            let lib = match lib {
                Some(l) => PathBuf::from(l),
                None => default_library()?,
            };
            scm::pack::pack(Path::new(&scene), &lib, Path::new(&out)).map_err(|e| e.to_string())?;
            eprintln!("wrote {out}");
            Ok(())
        }
        other => Err(format!("unknown command '{other}'\n{USAGE}")),
    }
}

fn positional<const N: usize>(args: &[String], names: &[&str; N]) -> Result<[String; N], String> {
    if let Some(flag) = args.iter().find(|a| a.starts_with('-')) {
        return Err(format!("unknown option {flag}\n{USAGE}"));
    }
    <[String; N]>::try_from(args.to_vec())
        .map_err(|_| format!("expected {}\n{USAGE}", names.join(" ")))
}

/// `libscm.so` next to this executable (cargo puts both in `target/<profile>/`).
fn default_library() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let lib = exe.with_file_name("libscm.so");
    if lib.is_file() {
        Ok(lib)
    } else {
        Err(format!(
            "{} not found: build it with `cargo build --release` or pass --lib",
            lib.display()
        ))
    }
}

fn simulate(
    sim: &mut Simulation,
    duration: f64,
    h: f64,
    out: Option<PathBuf>,
) -> Result<(), String> {
    let outputs: Vec<(String, u32)> = sim
        .info()
        .variables
        .iter()
        .filter(|v| {
            matches!(v.var_type, VarType::Real { .. })
                && v.causality == scm::fmi::contract::Causality::Output
        })
        .map(|v| (v.name.clone(), v.value_reference))
        .collect();
    let mut w: Box<dyn Write> = match &out {
        Some(p) => Box::new(std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?,
        )),
        None => Box::new(std::io::stdout().lock()),
    };
    let header: Vec<&str> = std::iter::once("time")
        .chain(outputs.iter().map(|(n, _)| n.as_str()))
        .collect();
    writeln!(w, "{}", header.join(",")).map_err(|e| e.to_string())?;
    let n = (duration / h).round() as usize;
    let start = std::time::Instant::now();
    for k in 0..=n {
        if k > 0 {
            sim.do_step((k - 1) as f64 * h, h)
                .map_err(|e| e.to_string())?;
        }
        let mut row = vec![format!("{}", k as f64 * h)];
        for (_, vr) in &outputs {
            row.push(format!("{}", sim.get_real(*vr)?));
        }
        writeln!(w, "{}", row.join(",")).map_err(|e| e.to_string())?;
    }
    if let Some(p) = out {
        eprintln!(
            "wrote {} ({} steps of {h} s in {:.3} s wall time)",
            p.display(),
            n,
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

fn check(path: &Path) -> Result<(), String> {
    // Everything `scm pack` would refuse, all at once, before the colliders are built.
    let compiled = scm::scene::compile(path).map_err(|e| e.to_string())?;
    if !compiled.refused.is_empty() {
        for w in &compiled.warnings {
            println!("warning: {w}");
        }
        for u in &compiled.unused {
            println!("unused: {u}");
        }
        for e in &compiled.refused {
            println!("refused: {e}");
        }
        return Err(format!(
            "{} refusal(s) in {}: scm pack would refuse this scene",
            compiled.refused.len(),
            path.display()
        ));
    }
    let sc = scm::scene::load(path).map_err(|e| e.to_string())?;
    let m = &sc.model;
    println!(
        "scene {} ({}): {} bodies, {} joints ({} positions, {} velocities), {} actuators",
        m.name,
        path.display(),
        m.tree.bodies.len() - 1,
        m.tree.joints.len(),
        m.tree.nq,
        m.tree.nv,
        m.actuators.len()
    );
    println!(
        "integrator {}, internal step {} s",
        m.integrator.name(),
        m.step
    );
    for a in &sc.meshes {
        let mp = a.mesh.mass_properties();
        println!(
            "mesh {} ({}): {} vertices, {} triangles, volume {:.4e} m³{}",
            a.name,
            a.path.display(),
            a.mesh.vertices.len(),
            a.mesh.triangles.len(),
            mp.volume,
            if a.used { "" } else { " (unused)" }
        );
    }
    let mut problems = Vec::new();
    for (b, body) in m.tree.bodies.iter().enumerate() {
        match &m.colliders[b] {
            None => println!("body {}: no collider", body.name),
            Some(scm::collision::Collider::HalfSpace { normal, .. }) => println!(
                "body {}: plane (exact half-space), normal {:?}",
                body.name,
                normal.as_slice()
            ),
            Some(scm::collision::Collider::Aopc(s)) => {
                let parts: Vec<_> = sc
                    .geoms
                    .iter()
                    .filter(|g| g.body == b)
                    .filter_map(|g| g.shape.clone().map(|s| (s, g.pose)))
                    .collect();
                let (exact, is_exact) = scm::geometry::union::union_volume(&parts);
                let size = parts
                    .iter()
                    .map(|(s, p)| s.size() + p.translation.vector.norm())
                    .fold(0.0, f64::max);
                let closure = s.closure_defect().norm();
                let volume = s.enclosed_volume();
                println!(
                    "body {}: {} geom(s), {} points, {} quads, {} vertices, spacing {:.4} m, |Σ n·area| = {:.2e} m², enclosed volume {:.4e} m³ ({} {:.4e} m³, {:+.2} %)",
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
                // The faces of a closed surface have Σ n·area = 0; the AOPC's volume is that of
                // its quads (chords of curved surfaces), within a few per mille of the shape's
                // at a sensible spacing.
                if closure > 1e-3 * size * size {
                    problems.push(format!(
                        "body {}: the surface is not closed (|Σ n·area| = {closure:.2e} m²)",
                        body.name
                    ));
                }
                let allowed = if is_exact { 0.02 } else { 0.05 };
                if (volume - exact).abs() > allowed * exact {
                    problems.push(format!("body {}: enclosed volume {volume:.4e} m³ differs from the geoms' {exact:.4e} m³ by more than {} %: interior or missing faces, or a spacing too coarse for the shape", body.name, allowed * 100.0));
                }
            }
        }
    }
    for p in &m.pairs {
        println!(
            "pair {} - {}",
            m.tree.bodies[p.a].name, m.tree.bodies[p.b].name
        );
    }
    if m.contact_points > 0 {
        println!("contact points: {} per pair", m.contact_points);
    }
    for w in &sc.warnings {
        println!("warning: {w}");
    }
    for u in &sc.unused {
        println!("unused: {u}");
    }
    for p in &problems {
        println!("problem: {p}");
    }
    if problems.is_empty() {
        println!("no problems found");
        Ok(())
    } else {
        Err(format!(
            "{} problem(s) found in {}",
            problems.len(),
            path.display()
        ))
    }
}
