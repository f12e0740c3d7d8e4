//! `scm`: pack scenes into FMUs, inspect their point clouds, check and simulate them
//! (`scm --help`, `scm COMMAND --help`).

use clap::{Parser, Subcommand};
use scm::fmi::contract::{FmiModel, VarType};
use scm::fmi::model_description::format_real;
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
        /// The FMU binary to pack (default: libscm.so next to this program, else in ../lib/scm/
        /// beside it, where the wheel installs it).
        #[arg(long, value_name = "PATH")]
        lib: Option<PathBuf>,
    },
    /// Simulate a scene natively through the FMU's own code; write the outputs as CSV (full
    /// precision), one row per output interval: every output, or those `--outputs` selects.
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
        /// Integrator: euler, semi_implicit_euler, damped_euler, rk4, damped_rk4, implicit_euler, dopri5
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
        /// The columns to write after `time`: output names or glob patterns
        /// (`root.pos.*,contact.*.force.*`), comma-separated or repeated, each matching at least
        /// one output; the columns keep the patterns' order (default: every output). Only what
        /// is written is computed: a contact's `.distance` evaluates every pair in full, which
        /// on a robot's self-collision pairs costs more than the step itself.
        #[arg(long = "outputs", value_name = "PATTERNS", value_delimiter = ',')]
        outputs: Vec<String>,
    },
    /// Print a body's oriented point cloud as CSV x,y,z,nx,ny,nz (body frame).
    Aopc {
        /// The scene (MJCF).
        scene: PathBuf,
        /// The body's name.
        body: String,
    },
    /// Report a scene's bodies, point clouds (with warnings where a cloud is not closed or
    /// misses its geoms' volume), pairs (with a warning where a pair pushes at the initial
    /// pose while its sampled points lie outside the other body's hull), warnings, what SCM
    /// leaves unused, and every refusal
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
    /// causality, variability, start, unit, description; a tab, newline or backslash within a
    /// field written \t, \n, \\): what a C host needs to call it.
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

mod check;
mod misread;
use check::check;

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
            outputs,
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
            let columns = columns(&sim, &outputs)?;
            let h = output_interval.unwrap_or(sim.model.timestep.max(0.01));
            simulate(&mut sim, duration, h, &columns, output)
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
                start.map(format_real).unwrap_or_default(),
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
            "{}\t{}\t{kind}\t{}\t{}\t{}\t{unit}\t{}",
            v.value_reference,
            field(&v.name),
            causality_name(v.causality),
            variability_name(v.variability),
            field(&start),
            field(&v.description)
        );
    }
    Ok(())
}

/// A field of `scm variables`' rows, one line and no tab: a backslash, tab, newline or
/// carriage return (an MJCF name may hold one, written `&#9;`) as `\\`, `\t`, `\n`, `\r`.
fn field(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '\\' => out.push_str("\\\\"),
            '\t' => out.push_str("\\t"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            c => out.push(c),
        }
    }
    out
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

/// The FMU binary this `scm` packs by default: `libscm.so` next to the executable (cargo puts
/// both in `target/<profile>/`), else in `../lib/scm/` beside it (where the wheel installs it:
/// `<prefix>/bin/scm` and `<prefix>/lib/scm/libscm.so`, see docs/wheel.md).
fn default_library() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let beside = exe.with_file_name("libscm.so");
    let installed = exe
        .parent()
        .and_then(Path::parent)
        .map(|prefix| prefix.join("lib").join("scm").join("libscm.so"));
    let candidates: Vec<PathBuf> = std::iter::once(beside).chain(installed).collect();
    match candidates.iter().find(|lib| lib.is_file()) {
        Some(lib) => Ok(lib.clone()),
        None => Err(format!(
            "the FMU binary libscm.so is neither at {}: build it with `cargo build --release`, \
             reinstall the wheel, or pass --lib",
            candidates
                .iter()
                .map(|c| c.display().to_string())
                .collect::<Vec<_>>()
                .join(" nor at ")
        )),
    }
}

/// The outputs `scm simulate --outputs` selects, as indices into
/// [`Simulation::output_names`]: each pattern's matches in the outputs' order, the patterns in
/// theirs, an output once (every output when there is no pattern).
fn columns(sim: &Simulation, patterns: &[String]) -> Result<Vec<usize>, String> {
    let names = sim.output_names();
    if patterns.is_empty() {
        return Ok((0..names.len()).collect());
    }
    let mut picked: Vec<usize> = Vec::new();
    for text in patterns {
        let pattern = glob::Pattern::new(text)
            .map_err(|e| format!("--outputs {text}: not a glob pattern ({e})"))?;
        let matches: Vec<usize> = (0..names.len())
            .filter(|&i| pattern.matches(names[i]))
            .collect();
        if matches.is_empty() {
            return Err(format!(
                "--outputs {text}: no output of {} matches; `scm variables` lists them (causality output)",
                sim.model.name
            ));
        }
        picked.extend(
            matches
                .into_iter()
                .filter(|i| !picked.contains(i))
                .collect::<Vec<_>>(),
        );
    }
    Ok(picked)
}

fn simulate(
    sim: &mut Simulation,
    duration: f64,
    h: f64,
    columns: &[usize],
    out: Option<PathBuf>,
) -> Result<(), Failure> {
    sim.initialize()?;
    let mut w: Box<dyn Write> = match &out {
        Some(p) => Box::new(std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?,
        )),
        None => Box::new(std::io::stdout().lock()),
    };
    let names = sim.output_names();
    let header: Vec<&str> = std::iter::once("time")
        .chain(columns.iter().map(|&i| names[i]))
        .collect();
    say!(w, "{}", header.join(","));
    // Rows every `h`, the last one exactly at `duration` (its step may be shorter). Each call
    // advances by `h` itself, as FMI hosts do, not by the difference of two row times, which
    // differs from `h` by a rounding: the steps inside are then all alike (the last call's
    // rounds to `h` where it is within 1e-9 of it).
    let n = (duration / h * (1.0 - 1e-12)).ceil().max(1.0) as usize;
    let at = |k: usize| (k as f64 * h).min(duration);
    let step = |k: usize| {
        let d = if k < n { h } else { duration - at(k - 1) };
        if (d - h).abs() <= 1e-9 * h {
            h
        } else {
            d
        }
    };
    let start = std::time::Instant::now();
    let mut progress: Option<indicatif::ProgressBar> = None;
    for k in 0..=n {
        if k > 0 {
            // From the row's time as the communication point, as an FMI host calls it: the
            // time reported is `at(k - 1) + step(k)`, not a sum of rounded steps.
            sim.do_step(at(k - 1), step(k)).map_err(|e| e.to_string())?;
        }
        let row: Vec<String> = std::iter::once(at(k))
            .chain(sim.outputs_of(columns)?)
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
    // Cleared when dropped, so a run that fails does not leave a full bar behind.
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(PROGRESS_UNITS),
        indicatif::ProgressDrawTarget::stderr(),
    )
    .with_finish(indicatif::ProgressFinish::AndClear);
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

#[cfg(test)]
mod tests {
    use super::{csv_number, field};

    #[test]
    fn variables_fields_stay_on_one_line_without_tabs() {
        assert_eq!(field("ball.pos.z"), "ball.pos.z");
        assert_eq!(field("a\tb\nc\rd\\e"), "a\\tb\\nc\\rd\\\\e");
    }

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
