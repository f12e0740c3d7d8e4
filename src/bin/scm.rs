//! `scm`: pack scenes into FMUs, inspect their point clouds, check and simulate them
//! (`scm --help`, `scm COMMAND --help`).

use clap::{Parser, Subcommand};
use scm::fmi::contract::{FmiModel, VarType};
use scm::sim::{Simulation, Value};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Soft-minimum contact (SCM): MJCF scenes as FMI 2.0 FMUs.
#[derive(Parser)]
#[command(name = "scm", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build an FMU (Co-Simulation and Model Exchange) of a scene, carrying only what it needs.
    Pack {
        /// The scene (MJCF).
        scene: PathBuf,
        /// The FMU to write.
        #[arg(short, long, value_name = "OUT.fmu")]
        output: PathBuf,
        /// The FMU binary to pack (default: libscm.so next to this program).
        #[arg(long, value_name = "PATH")]
        lib: Option<PathBuf>,
    },
    /// Simulate a scene natively through the FMU's own code; write every output as CSV (full
    /// precision), one row per output interval.
    Simulate {
        /// The scene (MJCF).
        scene: PathBuf,
        /// Simulated time (s).
        #[arg(long, default_value_t = 1.0, value_parser = positive, allow_hyphen_values = true)]
        duration: f64,
        /// Time between CSV rows, each one communication step (s; default: the scene's
        /// internal step, at least 0.01 s).
        #[arg(long, value_name = "S", value_parser = positive, allow_hyphen_values = true)]
        output_interval: Option<f64>,
        /// Internal step of the integrator (s; default: the scene's), i.e. `solver.step`.
        #[arg(long, value_name = "S", value_parser = positive, allow_hyphen_values = true)]
        step: Option<f64>,
        /// Integrator: euler, semi_implicit_euler, damped_euler, rk4, implicit_euler, dopri5
        /// (default: the scene's), i.e. `solver.integrator`.
        #[arg(long, value_name = "NAME")]
        integrator: Option<String>,
        /// Set an FMU variable before the run: a parameter (`scm.stiffness=1e5`), an initial
        /// state (`hinge.q=0.3`, `ball.linvel.z=-1`) or an input (`act.ctrl=0.5`). Repeatable.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        sets: Vec<String>,
        /// The CSV file (default: standard output).
        #[arg(short, long, value_name = "OUT.csv")]
        output: Option<PathBuf>,
    },
    /// Print a body's oriented point cloud as CSV x,y,z,nx,ny,nz (body frame).
    Aopc {
        /// The scene (MJCF).
        scene: PathBuf,
        /// The body's name.
        body: String,
    },
    /// Report a scene's bodies, point clouds (with warnings where a cloud is not closed or
    /// misses its geoms' volume), pairs, warnings, what SCM leaves unused, and every refusal
    /// with file and line; fails exactly where `pack` would refuse.
    Check {
        /// The scene (MJCF).
        scene: PathBuf,
    },
    /// Print the compiled model as JSON, in MuJoCo's conventions.
    Compile {
        /// The scene (MJCF).
        scene: PathBuf,
    },
    /// List the variables of the scene's FMU as its modelDescription.xml declares them: first
    /// its GUID, then one tab-separated row per variable (value reference, name, type,
    /// causality, variability, start, unit, description): what a C host needs to call it.
    Variables {
        /// The scene (MJCF).
        scene: PathBuf,
    },
}

fn positive(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|x| x.is_finite() && *x > 0.0)
        .ok_or_else(|| format!("'{s}' is not a positive number"))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli.command) {
        // The reader took what it wanted (`scm check scene.xml | head -1`): nothing is wrong.
        Ok(()) | Err(Failure::Closed) => ExitCode::SUCCESS,
        Err(Failure::Message(e)) => {
            eprintln!("scm: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Why a command stopped early.
enum Failure {
    /// What went wrong, for the user.
    Message(String),
    /// Standard output was closed by its reader.
    Closed,
}

impl From<String> for Failure {
    fn from(message: String) -> Self {
        Failure::Message(message)
    }
}

impl Failure {
    /// A failed write: [`Failure::Closed`] for a closed pipe.
    fn io(e: std::io::Error) -> Self {
        match e.kind() {
            std::io::ErrorKind::BrokenPipe => Failure::Closed,
            _ => Failure::Message(e.to_string()),
        }
    }
}

/// `writeln!` to `w`, a failed write ending the command ([`Failure::io`]).
macro_rules! say {
    ($w:expr, $($arg:tt)*) => {
        writeln!($w, $($arg)*).map_err(Failure::io)?
    };
}

fn run(command: Command) -> Result<(), Failure> {
    match command {
        Command::Simulate {
            scene,
            duration,
            output_interval,
            step,
            integrator,
            sets,
            output,
        } => {
            let mut sim = Simulation::from_file(&scene).map_err(|e| e.to_string())?;
            let mut sets = sets;
            if let Some(name) = integrator {
                sets.insert(0, format!("solver.integrator={name}"));
            }
            if let Some(h) = step {
                sets.insert(0, format!("solver.step={h}"));
            }
            for s in &sets {
                set_variable(&mut sim, s)?;
            }
            let h = output_interval.unwrap_or(sim.model.step.max(0.01));
            simulate(&mut sim, duration, h, output)
        }
        Command::Compile { scene } => {
            let c = scm::scene::compile(&scene).map_err(|e| e.to_string())?;
            let text = serde_json::to_string_pretty(&c.to_json()).map_err(|e| e.to_string())?;
            say!(std::io::stdout().lock(), "{text}");
            Ok(())
        }
        Command::Aopc { scene, body } => {
            let sc = scm::scene::load(&scene).map_err(|e| e.to_string())?;
            let b = sc
                .model
                .tree
                .bodies
                .iter()
                .position(|b| b.name == body)
                .ok_or_else(|| format!("{}: no body named '{body}'", scene.display()))?;
            let stdout = std::io::stdout();
            let mut w = stdout.lock();
            say!(w, "x,y,z,nx,ny,nz");
            match &sc.model.colliders[b] {
                Some(scm::collision::Collider::Aopc(s)) => {
                    for (p, n) in s.points.iter().zip(&s.normals) {
                        say!(w, "{},{},{},{},{},{}", p.x, p.y, p.z, n.x, n.y, n.z);
                    }
                }
                Some(scm::collision::Collider::HalfSpace { .. }) => {
                    return Err(format!(
                        "body '{body}' is a plane (an exact half-space, not a point cloud)"
                    )
                    .into())
                }
                None => return Err(format!("body '{body}' has no collision geometry").into()),
            }
            Ok(())
        }
        Command::Check { scene } => check(&scene, &mut std::io::stdout().lock()),
        Command::Variables { scene } => {
            let sim = Simulation::from_file(&scene).map_err(|e| e.to_string())?;
            variables(&sim, &mut std::io::stdout().lock())
        }
        Command::Pack { scene, output, lib } => {
            let lib = match lib {
                Some(l) => l,
                None => default_library()?,
            };
            scm::pack::pack(&scene, &lib, &output).map_err(|e| e.to_string())?;
            eprintln!("wrote {}", output.display());
            Ok(())
        }
    }
}

/// The FMU's GUID and its variables, one tab-separated row each (`scm variables`).
fn variables(sim: &Simulation, w: &mut impl Write) -> Result<(), Failure> {
    use scm::fmi::model_description::{causality_name, variability_name};
    let info = sim.info();
    say!(w, "guid\t{}", info.guid);
    say!(
        w,
        "value reference\tname\ttype\tcausality\tvariability\tstart\tunit\tdescription"
    );
    for v in &info.variables {
        let (kind, start, unit) = match &v.var_type {
            VarType::Real { start, unit, .. } => (
                "Real",
                start.map(csv_number).unwrap_or_default(),
                unit.unwrap_or(""),
            ),
            VarType::Integer { start } => (
                "Integer",
                start.map(|s| s.to_string()).unwrap_or_default(),
                "",
            ),
            VarType::Boolean { start } => (
                "Boolean",
                start.map(|s| s.to_string()).unwrap_or_default(),
                "",
            ),
            VarType::String { start } => ("String", start.clone().unwrap_or_default(), ""),
        };
        say!(
            w,
            "{}\t{}\t{kind}\t{}\t{}\t{start}\t{unit}\t{}",
            v.value_reference,
            v.name,
            causality_name(v.causality),
            variability_name(v.variability),
            v.description
        );
    }
    Ok(())
}

/// `NAME=VALUE` for an FMU variable, set as a host sets it before initialization (so its
/// checks apply: an output, a non-finite value or an unknown integrator is refused).
fn set_variable(sim: &mut Simulation, assignment: &str) -> Result<(), String> {
    let (name, value) = assignment
        .split_once('=')
        .ok_or_else(|| format!("--set {assignment}: expected NAME=VALUE"))?;
    let result = match sim.variable(name).map(|(v, _)| &v.var_type) {
        Ok(VarType::String { .. }) => sim.set(name, Value::Text(value)),
        Ok(_) => match value.trim().parse::<f64>() {
            Ok(x) => sim.set(name, Value::Real(x)),
            Err(_) => Err(format!("'{value}' is not a number")),
        },
        Err(e) => Err(e),
    };
    result.map_err(|e| format!("--set {assignment}: {e}"))
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
) -> Result<(), Failure> {
    sim.initialize()?;
    let mut w: Box<dyn Write> = match &out {
        Some(p) => Box::new(std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?,
        )),
        None => Box::new(std::io::stdout().lock()),
    };
    let header: Vec<&str> = std::iter::once("time").chain(sim.output_names()).collect();
    say!(w, "{}", header.join(","));
    // Rows every `h`, the last one exactly at `duration` (its step may be shorter).
    let n = (duration / h * (1.0 - 1e-12)).ceil().max(1.0) as usize;
    let at = |k: usize| (k as f64 * h).min(duration);
    let start = std::time::Instant::now();
    let mut progress: Option<indicatif::ProgressBar> = None;
    for k in 0..=n {
        if k > 0 {
            sim.step(at(k) - at(k - 1)).map_err(|e| e.to_string())?;
        }
        let row: Vec<String> = std::iter::once(at(k))
            .chain(sim.outputs()?)
            .map(csv_number)
            .collect();
        say!(w, "{}", row.join(","));
        if progress.is_none() && k < n && start.elapsed() > PROGRESS_AFTER {
            progress = Some(progress_bar(duration));
        }
        if let Some(p) = &progress {
            p.set_position((at(k) / duration * PROGRESS_UNITS as f64) as u64);
        }
    }
    if let Some(p) = progress {
        p.finish_and_clear();
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

/// A run that has taken this long shows its progress on standard error (on a terminal).
const PROGRESS_AFTER: std::time::Duration = std::time::Duration::from_secs(2);
/// The progress bar's length in units (its position is the simulated fraction of the run).
const PROGRESS_UNITS: u64 = 10_000;

/// The progress of `scm simulate` on standard error, updated at each CSV row: the simulated time
/// against the duration, the wall time and an estimate of what is left. Drawn only where
/// standard error is a terminal (indicatif hides it otherwise), so pipes and logs stay clean.
fn progress_bar(duration: f64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(PROGRESS_UNITS),
        indicatif::ProgressDrawTarget::stderr(),
    );
    let style = indicatif::ProgressStyle::with_template(&format!(
        "simulating {{bar:30}} {{percent:>3}}% of {duration} s, {{elapsed}} so far, about {{eta}} left"
    ))
    .expect("a valid progress template");
    bar.set_style(style);
    bar
}

/// `x` as the shortest text that reads back to the same number, in scientific notation where
/// the plain one would run long (below 1e-5 or from 1e16 in magnitude, as Python writes
/// floats): `4.0167476953300866e-26`, not 0.0000000000000000000000000401....
fn csv_number(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-5..1e16).contains(&x.abs()) {
        x.to_string()
    } else {
        format!("{x:e}")
    }
}

fn check(path: &Path, w: &mut dyn Write) -> Result<(), Failure> {
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
        m.step
    );
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
                    a.path.display()
                );
                continue;
            }
        };
        let mp = mesh.mass_properties();
        say!(
            w,
            "mesh {} ({}): {what}{} vertices, {} triangles, volume {:.4e} m³{}",
            a.name,
            a.path.display(),
            mesh.vertices.len(),
            mesh.triangles.len(),
            mp.volume,
            if a.used { "" } else { " (unused)" }
        );
    }
    // What the clouds' own measures flag: not refusals (`scm pack` and the FMU take such a
    // cloud), warnings that a spacing or a mesh may want a look.
    let mut cloud_warnings = Vec::new();
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
                        g.spacing
                            .map(|h| format!("{} {}", g.name, scm::scene::spacing_text(&h)))
                    })
                    .collect::<Vec<_>>()
                    .join(", ");
                let (exact, is_exact) = scm::geometry::union::union_volume(&parts);
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
                // How each mesh geom's triangles became its points (`TriMesh::sample`).
                for g in sc.geoms.iter().filter(|g| g.body == b) {
                    let (Some(scm::geometry::Shape::Mesh(mesh)), Some(h)) = (&g.shape, &g.spacing)
                    else {
                        continue;
                    };
                    let uniform = h.coarse.min();
                    match mesh.simplified(uniform) {
                        Some(simple) => say!(
                    w,
                            "  geom {}: its mesh's {} triangles simplified to {} within {:.2} mm of the file's surface (estimate {:.2} mm{}), then sampled at {uniform} m",
                            g.name,
                            mesh.triangles.len(),
                            simple.mesh.triangles.len(),
                            simple.tolerance * 1e3,
                            simple.error * 1e3,
                            match simple.folds {
                                0 => String::new(),
                                n => format!("; {n} triangle(s) folded inward dropped"),
                            }
                        ),
                        None => say!(
                    w,
                            "  geom {}: sampled on its mesh's own {} triangles at {uniform} m (no simplification within {:.2} mm, nor within a tolerance halved {} times, keeps a closed surface with fewer triangles and the volume to {} %)",
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
                "stiffness {:.4e} N/m, dissipation velocity {:.4e} m/s, {} (solref {:?}, solimp {:?}, effective mass {:.4e} kg: MuJoCo rests at {:.3} mm)",
                l.stiffness,
                l.dissipation_velocity,
                if l.dissipation_force.is_finite() {
                    format!("dissipation force {:.4e} N", l.dissipation_force)
                } else {
                    "damping unbounded in depth (the paper's law)".to_string()
                },
                l.softness.solref,
                l.softness.solimp,
                l.mass,
                l.depth * 1e3
            ),
            None => "stiffness and dissipation velocity: scm_stiffness, scm_dissipation_velocity".into(),
        };
        let margin = if p.margin != 0.0 {
            format!(", margin {} m (its springs rest that far out)", p.margin)
        } else {
            String::new()
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
        say!(
            w,
            "pair {} - {}: friction {friction}{margin}{floor}, {law}",
            m.tree.bodies[p.a].name,
            m.tree.bodies[p.b].name
        );
    }
    if m.contact_points > 0 {
        say!(w, "contact points: {} per pair", m.contact_points);
    }
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

#[cfg(test)]
mod tests {
    use super::csv_number;

    #[test]
    fn csv_numbers_are_short_and_read_back_exactly() {
        for (x, text) in [
            (4.0167476953300866e-26, "4.0167476953300866e-26"),
            (-5.683268005448776e-13, "-5.683268005448776e-13"),
            (0.0, "0"),
            (0.5, "0.5"),
            (1e-5, "0.00001"),
            (9.03491036536643, "9.03491036536643"),
            (1.5e16, "1.5e16"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(csv_number(x), text);
        }
        let mut x = 1.234_567_890_123_456_7e-30;
        while x < 1e30 {
            for v in [x, -x] {
                let t = csv_number(v);
                assert_eq!(t.parse::<f64>().unwrap(), v, "{t}");
                assert!(t.len() <= 24, "{t}");
            }
            x *= 7.3;
        }
    }
}
