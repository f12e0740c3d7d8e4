//! A minimal FMI 2.0 Co-Simulation host in Rust for the report (`scripts/report/`): it drives an
//! unpacked FMU through the crate's own exported `fmi2*` functions (the same C ABI a host calls
//! in `scm.so`), so results carry real `fmi2Discard`s, and times are those of `fmi2DoStep`
//! without a Python interpreter in between.
//!
//! ```text
//! report_host integrators SCENE.xml
//!     JSON: every integrator of the crate (one enumeration, SPEC §2) with whether it reads
//!     `solver.tolerance` (found by running SCENE with two tolerances) and whether it is
//!     adaptive (reads the tolerance, and at a tight one barely depends on `solver.step`)
//! report_host run FMU_DIR --duration S --comm S [--set NAME=VALUE]... [--set-string NAME=VALUE]...
//!                 [--inputs FILE.csv] [--outputs NAME,NAME,...]
//!     JSON: status ("ok", "discard", "error"), message, the outputs at every communication
//!     point reached, and the wall time spent inside fmi2DoStep
//! ```
//! `FMU_DIR` is an unpacked FMU (its `resources/scene.xml` is the scene). `--set` values are
//! applied after `fmi2Instantiate`, before initialization (parameters, `solver.step`, start
//! values such as `J.q`). `--inputs` is a CSV whose header names input variables and whose row
//! `k` holds their values during communication step `k` (the last row is held). A non-finite
//! output is written as `null`: the report treats it as a bug and stops.
//!
//! The FMU's messages are collected by the crate's host-side [`scm::fmi::host_log`]
//! (x86_64 / AArch64 Linux).

use scm::fmi::ffi::*;
use scm::fmi::host_log::LogCapture;
#[path = "support/host.rs"]
mod host;
#[path = "support/json.rs"]
mod json;
use json::json_str;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("integrators") if args.len() == 2 => integrators(Path::new(&args[1])),
        Some("run") if args.len() >= 2 => run(&args[1..]),
        _ => Err("usage: report_host integrators SCENE.xml | report_host run FMU_DIR --duration S --comm S [--set N=V]... [--set-string N=V]... [--inputs F.csv] [--outputs A,B]".into()),
    };
    match result {
        Ok(json) => println!("{json}"),
        Err(e) => {
            eprintln!("report_host: {e}");
            std::process::exit(2);
        }
    }
}

fn json_num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:e}")
    } else {
        "null".into()
    }
}

/// Every integrator, whether its result depends on `solver.tolerance`, and whether it is
/// adaptive: it depends on the tolerance and, at a tight tolerance, hardly on `solver.step`
/// (an implicit method whose Newton iterations read the tolerance still changes with the step).
fn integrators(scene: &Path) -> Result<String, String> {
    use scm::fmi::contract::FmiModel;
    let mut items = Vec::new();
    for integrator in scm::integrate::Integrator::ALL.iter().copied() {
        let final_state = |tolerance: f64, step: f64| -> Result<Vec<f64>, String> {
            let mut sim = scm::sim::Simulation::from_file(scene).map_err(|e| e.to_string())?;
            sim.model.integrator = integrator;
            sim.model.tolerance = tolerance;
            sim.model.timestep = step;
            for k in 0..50 {
                // A refused step counts as a result too: compare what was reached.
                if sim.do_step(k as f64 * 0.01, 0.01).is_err() {
                    break;
                }
            }
            Ok(sim
                .data
                .current
                .state
                .q
                .iter()
                .chain(&sim.data.current.state.v)
                .copied()
                .collect())
        };
        let (loose, tight) = (final_state(1e-2, 0.01)?, final_state(1e-9, 0.01)?);
        let uses_tolerance = loose
            .iter()
            .zip(&tight)
            .any(|(a, b)| a.to_bits() != b.to_bits());
        let tight_half = final_state(1e-9, 0.005)?;
        let step_change = tight
            .iter()
            .zip(&tight_half)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let adaptive = uses_tolerance && step_change < 1e-6;
        items.push(format!(
            "{{\"name\": {}, \"uses_tolerance\": {uses_tolerance}, \"adaptive\": {adaptive}}}",
            json_str(integrator.name())
        ));
    }
    Ok(format!("[{}]", items.join(", ")))
}

struct Job {
    dir: PathBuf,
    duration: f64,
    comm: f64,
    reals: Vec<(String, f64)>,
    strings: Vec<(String, String)>,
    inputs: Option<(Vec<String>, Vec<Vec<f64>>)>,
    outputs: Vec<String>,
}

fn parse_job(args: &[String]) -> Result<Job, String> {
    let mut job = Job {
        dir: PathBuf::from(&args[0]),
        duration: f64::NAN,
        comm: f64::NAN,
        reals: vec![],
        strings: vec![],
        inputs: None,
        outputs: vec![],
    };
    let mut it = args[1..].iter();
    let pair = |s: &str| -> Result<(String, String), String> {
        s.split_once('=')
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .ok_or_else(|| format!("expected NAME=VALUE, got {s}"))
    };
    let num = |s: &str| -> Result<f64, String> {
        s.parse::<f64>().map_err(|_| format!("not a number: {s}"))
    };
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--duration" => job.duration = num(value)?,
            "--comm" => job.comm = num(value)?,
            "--set" => {
                let (n, v) = pair(value)?;
                job.reals.push((n, num(&v)?));
            }
            "--set-string" => job.strings.push(pair(value)?),
            "--outputs" => {
                job.outputs = value
                    .split(',')
                    .filter(|s| !s.is_empty())
                    .map(String::from)
                    .collect()
            }
            "--inputs" => {
                let text = std::fs::read_to_string(value).map_err(|e| format!("{value}: {e}"))?;
                let mut lines = text.lines();
                let header: Vec<String> = lines
                    .next()
                    .ok_or(format!("{value}: empty"))?
                    .split(',')
                    .map(|s| s.trim().to_string())
                    .collect();
                let rows = lines
                    .filter(|l| !l.trim().is_empty())
                    .map(|l| {
                        l.split(',')
                            .map(|s| num(s.trim()))
                            .collect::<Result<Vec<f64>, String>>()
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                if rows.is_empty() || rows.iter().any(|r| r.len() != header.len()) {
                    return Err(format!("{value}: every row needs {} values", header.len()));
                }
                job.inputs = Some((header, rows));
            }
            other => return Err(format!("unknown option {other}")),
        }
    }
    if !(job.duration > 0.0 && job.comm > 0.0) {
        return Err("--duration and --comm must be positive".into());
    }
    Ok(job)
}

fn run(args: &[String]) -> Result<String, String> {
    let job = parse_job(args)?;
    let messages = LogCapture::default();
    let last_message = |m: &LogCapture| match m.all().last() {
        Some(l) => format!("[{}] {}: {}", l.status, l.category, l.message),
        None => String::new(),
    };
    let with_message = |e: String| format!("{e}: {}", last_message(&messages));
    let fmu = host::Instance::new(
        &job.dir.join("resources"),
        fmi2CoSimulation,
        messages.callbacks(),
    )
    .map_err(with_message)?;
    let vrs = |names: &mut dyn Iterator<Item = &String>| -> Result<Vec<u32>, String> {
        names.map(|n| fmu.vr(n)).collect()
    };
    let out_vrs = vrs(&mut job.outputs.iter())?;
    let (in_vrs, in_rows) = match &job.inputs {
        Some((names, rows)) => (vrs(&mut names.iter())?, rows.clone()),
        None => (vec![], vec![]),
    };
    let n_steps = (job.duration / job.comm).round() as usize;
    fmu.setup(Some(n_steps as f64 * job.comm))
        .map_err(with_message)?;
    for (n, v) in &job.reals {
        fmu.set_real(&[fmu.vr(n)?], &[*v])
            .map_err(|e| with_message(format!("{e} ({n})")))?;
    }
    for (n, v) in &job.strings {
        fmu.set_string(fmu.vr(n)?, v)
            .map_err(|e| with_message(format!("{e} ({n})")))?;
    }
    fmu.initialize().map_err(with_message)?;

    let mut t_out = Vec::with_capacity(n_steps + 1);
    let mut y_out: Vec<Vec<f64>> = Vec::with_capacity(n_steps + 1);
    let mut y = vec![0.0; out_vrs.len()];
    let mut wall = 0.0;
    let mut status = "ok";
    for k in 0..=n_steps {
        if let Some(row) = in_rows.get(k.min(in_rows.len().saturating_sub(1))) {
            fmu.set_real(&in_vrs, row)
                .map_err(|e| with_message(format!("{e} (inputs)")))?;
        }
        fmu.get_real_into(&out_vrs, &mut y).map_err(with_message)?;
        t_out.push(k as f64 * job.comm);
        y_out.push(y.clone());
        if k == n_steps {
            break;
        }
        let start = Instant::now();
        let s = fmu.do_step(k as f64 * job.comm, job.comm);
        wall += start.elapsed().as_secs_f64();
        if s == fmi2Discard {
            status = "discard";
            break;
        } else if s > fmi2Warning {
            status = "error";
            break;
        }
    }
    drop(fmu);
    let message = if status == "ok" {
        String::new()
    } else {
        last_message(&messages)
    };
    let rows: Vec<String> = y_out
        .iter()
        .map(|r| {
            format!(
                "[{}]",
                r.iter().map(|&x| json_num(x)).collect::<Vec<_>>().join(",")
            )
        })
        .collect();
    Ok(format!(
        "{{\"status\": {}, \"message\": {}, \"wall_step_s\": {}, \"comm_steps\": {}, \"names\": [{}], \"t\": [{}], \"y\": [{}]}}",
        json_str(status),
        json_str(&message),
        json_num(wall),
        t_out.len().saturating_sub(1),
        job.outputs.iter().map(|n| json_str(n)).collect::<Vec<_>>().join(","),
        t_out.iter().map(|&t| json_num(t)).collect::<Vec<_>>().join(","),
        rows.join(",")
    ))
}
