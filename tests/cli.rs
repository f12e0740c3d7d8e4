//! The command line as a person uses it: help for every command, `simulate` with `--set`,
//! `--output-interval` and full-precision CSV, and every error as one readable line.

use crate::common::scene;
use std::process::{Command, Output};

fn scm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scm"))
        .args(args)
        .output()
        .expect("the scm binary runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn every_command_has_help() {
    let out = scm(&["--help"]);
    assert!(out.status.success());
    for cmd in ["pack", "simulate", "aopc", "check", "compile", "variables"] {
        assert!(text(&out.stdout).contains(cmd), "{cmd} not in the help");
        let sub = scm(&[cmd, "--help"]);
        assert!(sub.status.success(), "scm {cmd} --help failed");
        assert!(
            text(&sub.stdout).contains("Usage: scm"),
            "{}",
            text(&sub.stdout)
        );
    }
    let sim = text(&scm(&["simulate", "--help"]).stdout);
    for opt in [
        "--set",
        "--output-interval",
        "--duration",
        "--integrator",
        "--step",
    ] {
        assert!(sim.contains(opt), "simulate --help lacks {opt}");
    }
    // `--integrator` names every integrator a scene or `solver.integrator` can take.
    for i in scm::integrator::Integrator::ALL {
        assert!(
            sim.contains(&format!(" {},", i.name())) || sim.contains(&format!(" {} (", i.name())),
            "simulate --help's --integrator lacks {}",
            i.name()
        );
    }
}

#[test]
fn simulate_sets_variables_and_writes_rows_at_the_output_interval() {
    let drop = scene("sphere_drop");
    let out = scm(&[
        "simulate",
        drop.to_str().unwrap(),
        "--duration",
        "0.05",
        "--output-interval",
        "0.02",
        "--set",
        "ball.pos.z=0.5",
        "--set",
        "ball.linvel.x=1",
        "--set",
        "scm.stiffness=2e5",
        "--integrator",
        "rk4",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv = text(&out.stdout);
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    let col = |name: &str| rows[0].iter().position(|h| *h == name).unwrap();
    let times: Vec<&str> = rows[1..].iter().map(|r| r[0]).collect();
    assert_eq!(
        times,
        ["0", "0.02", "0.04", "0.05"],
        "the last row lands on the duration"
    );
    let (z, x) = (col("ball.pos.z"), col("ball.pos.x"));
    assert_eq!(rows[1][z], "0.5");
    // Free fall from 0.5 m at 1 m/s sideways, far above the floor: RK4 is exact on it, and
    // the CSV carries every digit (shortest round-trip form).
    let last = rows.last().unwrap();
    let (t, g) = (0.05f64, 9.81);
    let zf: f64 = last[z].parse().unwrap();
    let xf: f64 = last[x].parse().unwrap();
    assert!((zf - (0.5 - 0.5 * g * t * t)).abs() < 1e-12, "{zf}");
    assert!((xf - t).abs() < 1e-12, "{xf}");
}

/// The rows do not change the run: implicit Euler (Newton's iterations warm-started from the
/// last call) on a sphere dropped onto the floor ends in the same state, to the bit, with a row
/// every 0.01 s, every 0.03 s (the last call shorter) or one at the end. Each call advances by
/// the interval itself; advanced by the difference of two row times (which differs from the
/// interval by a rounding), gymnasium's ant ended 0.04 rad apart between rows of 0.01 s and 1 s.
#[test]
fn simulate_ends_in_the_same_state_whatever_the_output_interval() {
    let drop = scene("sphere_drop");
    let last_row = |interval: &str| {
        let out = scm(&[
            "simulate",
            drop.to_str().unwrap(),
            "--duration",
            "0.3",
            "--output-interval",
            interval,
            "--integrator",
            "implicit_euler",
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let csv = text(&out.stdout);
        let last = csv.lines().last().unwrap().to_owned();
        let header = csv.lines().next().unwrap().to_owned();
        (header, last)
    };
    let (header, one) = last_row("0.3");
    let z = header.split(',').position(|h| h == "ball.pos.z").unwrap();
    let z_end: f64 = one.split(',').nth(z).unwrap().parse().unwrap();
    assert!(z_end < 0.2, "the ball has landed: z = {z_end} m");
    for interval in ["0.01", "0.03"] {
        let (_, row) = last_row(interval);
        let state = |r: &str| -> Vec<String> {
            header
                .split(',')
                .zip(r.split(','))
                .filter(|(h, _)| h.starts_with("ball."))
                .map(|(_, v)| v.to_owned())
                .collect()
        };
        assert_eq!(state(&row), state(&one), "rows every {interval} s");
    }
}

/// `--outputs` writes the columns asked for, in the patterns' order, each once, with the
/// values of the run that writes them all; a pattern that matches nothing fails before any file
/// is written.
#[test]
fn simulate_writes_only_the_outputs_asked_for() {
    let drop = scene("sphere_drop");
    let run = |extra: &[&str]| {
        let mut args = vec!["simulate", drop.to_str().unwrap(), "--duration", "0.3"];
        args.extend(extra);
        let out = scm(&args);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let csv = text(&out.stdout);
        let rows: Vec<Vec<String>> = csv
            .lines()
            .map(|l| l.split(',').map(str::to_owned).collect())
            .collect();
        rows
    };
    let all = run(&[]);
    let some = run(&[
        "--outputs",
        "contact.*.force.z,ball.pos.z",
        "--outputs",
        "ball.pos.*",
    ]);
    let header: Vec<&str> = some[0].iter().map(String::as_str).collect();
    assert_eq!(
        header,
        [
            "time",
            "contact.world.ball.force.z",
            "ball.pos.z",
            "ball.pos.x",
            "ball.pos.y"
        ]
    );
    assert_eq!(some.len(), all.len());
    let at = |name: &str| all[0].iter().position(|h| h == name).unwrap();
    for (row, full) in some.iter().zip(&all).skip(1) {
        for (k, name) in header.iter().enumerate() {
            assert_eq!(row[k], full[at(name)], "{name} at t = {}", row[0]);
        }
    }
    let landed: f64 = some.last().unwrap()[1].parse().unwrap();
    assert!(
        landed < -1.0,
        "the ball rests on the floor: {landed} N on it"
    );

    let dir = std::env::temp_dir().join(format!("scm-cli-outputs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("out.csv");
    let out = scm(&[
        "simulate",
        drop.to_str().unwrap(),
        "--outputs",
        "ball.pos.w",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(!csv.exists(), "nothing written on a refusal");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn errors_are_one_readable_line() {
    let drop = scene("sphere_drop");
    let drop = drop.to_str().unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &["simulate", drop, "--set", "ball.pos.q=1"],
            "no variable 'ball.pos.q'",
        ),
        (
            &["simulate", drop, "--set", "scm.stiffness=-1"],
            "must be positive",
        ),
        (
            &["simulate", drop, "--set", "ball.linacc.z=1"],
            "ball.linacc.z (value reference",
        ),
        (
            &["simulate", drop, "--integrator", "foo"],
            "known integrators are",
        ),
        (
            &["simulate", drop, "--duration", "-1"],
            "not a positive number",
        ),
        (
            &["simulate", drop, "--outputs", "ball.pos.z,ball.pos.q*"],
            "--outputs ball.pos.q*: no output of",
        ),
        (
            &["simulate", drop, "--outputs", "ball.[pos"],
            "--outputs ball.[pos: not a glob pattern",
        ),
    ];
    for (args, words) in cases {
        let out = scm(args);
        assert!(!out.status.success(), "{args:?} must fail");
        let err = text(&out.stderr);
        assert!(err.contains(words), "{args:?}: '{words}' not in {err}");
    }
    // A scene error names the file and the line.
    let dir = std::env::temp_dir().join(format!("scm-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.xml");
    std::fs::write(&bad, "<mujoco>\n<worldbody>\n<body><joint type=\"hinge\" actuatorgravcomp=\"true\"/><geom size=\"0.1\"/></body>\n</worldbody>\n</mujoco>\n").unwrap();
    let out = scm(&["simulate", bad.to_str().unwrap()]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(&format!("{}:3:", bad.display())), "{err}");
    // Writing into a folder that is not there names the user's path, not a temporary file.
    let missing = dir.join("no_such_folder");
    for (args, path) in [
        (["pack", drop, "-o"], missing.join("x.fmu")),
        (["simulate", drop, "-o"], missing.join("x.csv")),
    ] {
        let out = scm(&[args[0], args[1], args[2], path.to_str().unwrap()]);
        let err = text(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.starts_with(&format!("scm: {}: ", path.display())) && !err.contains(".tmp"),
            "{err}"
        );
        assert!(!missing.exists());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `scm check` measures a body's sampled surface against its colliding geoms only: a
/// decoration that collides with nothing (dm_control's finger) is not part of the cloud, and
/// counting its volume made a well-sampled body a "problem".
#[test]
fn check_compares_a_body_with_its_colliding_geoms_only() {
    let dir = std::env::temp_dir().join(format!("scm-cli-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("finger.xml");
    let body = |decoration: &str| {
        format!("<mujoco>\n  <worldbody>\n    <geom type=\"plane\" size=\"1 1 0.1\"/>\n    <body pos=\"0 0 0.5\">\n      <joint axis=\"0 1 0\"/>\n      <geom type=\"capsule\" size=\"0.03\" fromto=\"0 0 -0.13 0 0 -0.16\"/>\n      <geom type=\"capsule\" size=\"0.028\" fromto=\"0 0 0 0 0 -0.16\"{decoration}/>\n    </body>\n  </worldbody>\n</mujoco>\n")
    };
    std::fs::write(&path, body(" contype=\"0\" conaffinity=\"0\"")).unwrap();
    let out = scm(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The one colliding geom gives all of its body's points, and says so, with its spacing
    // and why: a smooth shape of radius 3 cm, √(8 × 0.03 × 0.0005) = 1.095 cm floored to 0.1 mm.
    let stdout = text(&out.stdout);
    let head = "1 geom(s) (sampled at: body1_geom0 0.0109 m [the default for a smooth shape: 0.5 mm sagitta on its 0.03 m radius of curvature], ";
    let at = stdout.find(head).unwrap_or_else(|| panic!("{stdout}")) + head.len();
    let count = |s: &str| -> usize { s[..s.find(' ').unwrap()].parse().unwrap() };
    let own = count(&stdout[at..]);
    let rest = &stdout[at..];
    let body_points = count(&rest[rest.find("points), ").unwrap() + "points), ".len()..]);
    assert!(own > 0 && own == body_points, "{stdout}");
    // Both colliding: both are sampled and measured.
    std::fs::write(&path, body("")).unwrap();
    let out = scm(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("2 geom(s)"),
        "{}",
        text(&out.stdout)
    );
    // No pruning tolerance line at the default; the scene's, where it sets one.
    assert!(!text(&out.stdout).contains("pruning tolerance"));
    let loose = body("").replace(
        "<worldbody>",
        "<custom><numeric name=\"scm_prune_tolerance\" data=\"1e-9\"/></custom>\n  <worldbody>",
    );
    std::fs::write(&path, loose).unwrap();
    let out = scm(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout)
            .contains("pruning tolerance 1e-9 (scm_prune_tolerance; the default is 1e-15)"),
        "{}",
        text(&out.stdout)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn variables_lists_the_guid_and_every_variable_as_the_model_description_declares_it() {
    let drop = scene("sphere_drop");
    let out = scm(&["variables", drop.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let listed = text(&out.stdout);
    let lines: Vec<&str> = listed.lines().collect();
    let text_of_scene = std::fs::read_to_string(&drop).unwrap();
    assert_eq!(
        lines[0],
        format!("guid\t{}", scm::sim::guid(&text_of_scene))
    );
    assert_eq!(
        lines[1],
        "value reference\tname\ttype\tcausality\tvariability\tstart\tunit\tdescription"
    );
    // Every variable of the packed model description, once, with its value reference.
    let xml = scm::pack::describe(&drop).unwrap().model_description;
    let declared = xml.matches("<ScalarVariable").count();
    assert_eq!(lines.len() - 2, declared);
    let rows: Vec<Vec<&str>> = lines[2..].iter().map(|l| l.split('\t').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == 8), "{rows:?}");
    let z = rows
        .iter()
        .find(|r| r[1] == "ball.pos.z")
        .expect("ball.pos.z listed");
    assert!(
        xml.contains(&format!("name=\"ball.pos.z\" valueReference=\"{}\"", z[0])),
        "{z:?}"
    );
    assert_eq!((z[2], z[6]), ("Real", "m"), "{z:?}");
    // Each start value as the XML writes it (`1.0`, `INF`, `true`), so the two read alike.
    let mut starts = 0;
    for r in &rows {
        let at = xml
            .find(&format!("name=\"{}\" valueReference=\"{}\"", r[1], r[0]))
            .unwrap_or_else(|| panic!("{r:?} not declared"));
        let element = &xml[at..at + xml[at..].find("</ScalarVariable>").unwrap()];
        if r[5].is_empty() {
            assert!(!element.contains("start=\""), "{r:?}: {element}");
        } else {
            assert!(
                element.contains(&format!("start=\"{}\"", r[5])),
                "{r:?}: {element}"
            );
            starts += 1;
        }
    }
    assert!(starts > 10, "{starts} start values");
}

/// A reader that takes the first line and closes the pipe (`scm … | head -1`) ends the
/// command quietly with success: no panic, nothing on standard error. Each output here is
/// many times a pipe's buffer (64 KiB), so the command is still writing when the pipe closes.
#[test]
fn a_reader_that_closes_the_pipe_early_ends_the_command_quietly() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let drop = scene("sphere_drop");
    let drop = drop.to_str().unwrap();
    // Forty spheres: 780 pairs for `check` to list (160 kB), 355 kB of compiled model.
    let dir = std::env::temp_dir().join(format!("scm-cli-pipe-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let many = dir.join("many.xml");
    let bodies: String = (0..40)
        .map(|i| {
            format!(
                r#"<body name="s{i}" pos="{} 0 1"><freejoint/><geom type="sphere" size="0.1"/></body>"#,
                0.3 * i as f64
            )
        })
        .collect();
    std::fs::write(
        &many,
        format!("<mujoco><worldbody>{bodies}</worldbody></mujoco>"),
    )
    .unwrap();
    let many = many.to_str().unwrap();
    let commands: [&[&str]; 5] = [
        &[
            "simulate",
            drop,
            "--duration",
            "20",
            "--output-interval",
            "0.001",
        ],
        &["check", many],
        &["compile", many],
        &["aopc", many, "s0"],
        &["variables", many],
    ];
    for args in commands {
        let mut child = Command::new(env!("CARGO_BIN_EXE_scm"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut first = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        assert!(!first.is_empty(), "{args:?} printed nothing");
        // The reader is dropped here: the pipe is closed.
        let out = child.wait_with_output().unwrap();
        let err = text(&out.stderr);
        assert!(
            out.status.success() && err.is_empty(),
            "{args:?}: {:?} {err}",
            out.status
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `scm check` prints, per pair, the ε1 each body's planes are read with: the parameter as it
/// is for a cloud at 1 cm, a quarter of it for one at 5 mm, with its longest quad
/// (docs/method.md, "ε1 follows the spacing").
#[test]
fn check_prints_the_eps1_of_each_bodys_planes() {
    let dir = std::env::temp_dir().join(format!("scm-cli-eps1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("boxes.xml");
    std::fs::write(
        &path,
        r#"<mujoco>
  <custom><numeric name="scm_spacing" data="0.01"/><numeric name="scm_spacing:hi" data="0.005"/></custom>
  <worldbody>
    <body name="low"><freejoint/><geom name="lo" type="box" size="0.04 0.04 0.04"/></body>
    <body name="high" pos="0 0 0.1"><freejoint/><geom name="hi" type="box" size="0.04 0.04 0.04"/></body>
  </worldbody>
</mujoco>
"#,
    )
    .unwrap();
    let out = scm(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("pair low - high"))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(
        line.contains("ε1 of low's planes 1.0000e-5 m² (scm.eps1), ε1 of high's planes 2.5000e-6 m² (scm.eps1 times 0.2500: its longest quad is 0.0050 m, finer than 0.01 m)"),
        "{line}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `scm check` says which hull a mesh collides by, and warns where that hull fills far more
/// than the mesh: an L of 5 cm arms 5 mm thick encloses 9.5 cm³, its hull 29.75 cm³ (3.1
/// times), which a body resting in the L's corner would touch in MuJoCo as in SCM.
#[test]
fn check_names_each_meshs_hull_and_warns_where_it_fills_concave_parts() {
    let dir = std::env::temp_dir().join(format!("scm-cli-hull-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("l.obj"),
        "v 0 -0.01 0\nv 0.05 -0.01 0\nv 0.05 -0.01 0.005\nv 0.005 -0.01 0.005\nv 0.005 -0.01 0.05\n\
         v 0 -0.01 0.05\nv 0 0.01 0\nv 0.05 0.01 0\nv 0.05 0.01 0.005\nv 0.005 0.01 0.005\n\
         v 0.005 0.01 0.05\nv 0 0.01 0.05\nf 1 2 3 4 5 6\nf 12 11 10 9 8 7\nf 1 7 8 2\nf 2 8 9 3\n\
         f 3 9 10 4\nf 4 10 11 5\nf 5 11 12 6\nf 6 12 7 1\n",
    )
    .unwrap();
    let scene = |custom: &str| {
        format!(
            r#"<mujoco>
  <custom>{custom}</custom>
  <asset><mesh name="l" file="l.obj"/></asset>
  <worldbody><body name="l"><freejoint/><geom name="l" type="mesh" mesh="l"/></body>
    <body name="ball" pos="0.02 0 0.02"><freejoint/><geom type="sphere" size="0.005"/></body></worldbody>
</mujoco>
"#
        )
    };
    let path = dir.join("l.xml");
    std::fs::write(&path, scene("")).unwrap();
    let out = scm(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("; collides by its convex hull, as in MuJoCo: ")
            && stdout.contains("geom l: its mesh's convex hull's"),
        "{stdout}"
    );
    assert!(
        stdout.contains("warning: mesh l: its convex hull, which MuJoCo and SCM collide by, encloses 3.1 times the mesh's volume"),
        "{stdout}"
    );
    // By its own surface: no hull, no warning.
    std::fs::write(
        &path,
        scene(r#"<text name="scm_mesh_collision" data="surface"/>"#),
    )
    .unwrap();
    let stdout = text(&scm(&["check", path.to_str().unwrap()]).stdout);
    assert!(
        !stdout.contains("convex hull") && stdout.contains("geom l: its mesh's "),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
