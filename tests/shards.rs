//! Suites and `tune` split over a Slurm job array: `--shard auto` read from the array's
//! environment, the run id each shard records, the merge's refusals (a missing shard,
//! shards of two runs), a rerun task replacing its shard whole, and `tune --shard`
//! merged into the search an unsharded `tune` makes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use sandbox2d::bench::Shard;
use sandbox2d::bench::slurm;

mod common;
use common::cli::{sandbox2d, tmp};

/// Every variable a Slurm array task has, so that a test's own environment (a CI job
/// that itself runs under Slurm) does not leak into the command.
const SLURM_VARS: [&str; 6] = [
    slurm::TASK_ID,
    slurm::TASK_MIN,
    slurm::TASK_MAX,
    slurm::TASK_COUNT,
    slurm::TASK_STEP,
    slurm::ARRAY_JOB_ID,
];

/// The command with no Slurm variable but `vars`.
fn with_env(vars: &[(&str, &str)]) -> Command {
    let mut c = sandbox2d();
    for v in SLURM_VARS {
        c.env_remove(v);
    }
    for (k, v) in vars {
        c.env(k, v);
    }
    c
}

/// An array task's variables, as (name, value).
type Vars<'a> = &'a [(&'a str, &'a str)];

fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
    move |k| {
        vars.iter()
            .find(|(name, _)| *name == k)
            .map(|(_, v)| v.to_string())
    }
}

/// A fresh scratch folder.
fn fresh(name: &str) -> PathBuf {
    let d = tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Expects a refusal: exit 2 and one line on stderr, which is returned.
fn refused(out: Output, what: &str) -> String {
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{what}: {err}");
    assert_eq!(err.lines().count(), 1, "{what}: {err}");
    assert!(err.starts_with("error: "), "{what}: {err}");
    err
}

fn succeeded(out: Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{what}: {err}");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn an_array_s_tasks_are_its_shards_in_index_order() {
    use slurm::TASK_STEP as STEP;
    use slurm::{TASK_COUNT as COUNT, TASK_ID as ID, TASK_MAX as MAX, TASK_MIN as MIN};
    let cases: &[(Vars, (usize, usize))] = &[
        // --array=0-3: task 0 is shard 1/4, task 3 is 4/4
        (&[(ID, "0"), (MIN, "0"), (MAX, "3"), (COUNT, "4")], (1, 4)),
        (&[(ID, "3"), (MIN, "0"), (MAX, "3"), (COUNT, "4")], (4, 4)),
        // --array=1-4
        (&[(ID, "2"), (MIN, "1"), (MAX, "4"), (COUNT, "4")], (2, 4)),
        // --array=10-12 with the step Slurm sets
        (
            &[
                (ID, "11"),
                (MIN, "10"),
                (MAX, "12"),
                (COUNT, "3"),
                (STEP, "1"),
            ],
            (2, 3),
        ),
        // --array=1-9:4 (tasks 1, 5, 9)
        (
            &[(ID, "9"), (MIN, "1"), (MAX, "9"), (COUNT, "3"), (STEP, "4")],
            (3, 3),
        ),
        // MIN and MAX alone, or MIN and COUNT alone
        (&[(ID, "5"), (MIN, "5"), (MAX, "6")], (1, 2)),
        (&[(ID, "6"), (MIN, "5"), (COUNT, "2")], (2, 2)),
        // a one-task array
        (&[(ID, "7"), (MIN, "7"), (MAX, "7"), (COUNT, "1")], (1, 1)),
    ];
    for (vars, (index, count)) in cases {
        let got = slurm::shard(env(vars));
        assert_eq!(
            got,
            Ok(Shard {
                index: *index,
                count: *count
            }),
            "{vars:?}"
        );
        // the tasks of the array cover every case once, as I/N does
        assert_eq!(slurm::resolve("auto", env(vars)), got);
    }
    assert_eq!(
        slurm::resolve("2/5", env(&[])),
        Ok(Shard { index: 2, count: 5 })
    );
}

#[test]
fn missing_or_inconsistent_array_variables_are_refused_in_one_line() {
    use slurm::TASK_STEP as STEP;
    use slurm::{TASK_COUNT as COUNT, TASK_ID as ID, TASK_MAX as MAX, TASK_MIN as MIN};
    let cases: &[(Vars, &str)] = &[
        (&[], "SLURM_ARRAY_TASK_ID is not set"),
        (&[(MIN, "0"), (MAX, "3")], "SLURM_ARRAY_TASK_ID is not set"),
        (&[(ID, "1"), (MAX, "3")], "SLURM_ARRAY_TASK_MIN is not"),
        (&[(ID, "1"), (MIN, "0")], "neither SLURM_ARRAY_TASK_MAX nor"),
        (
            &[(ID, "x"), (MIN, "0"), (MAX, "3")],
            "SLURM_ARRAY_TASK_ID=\"x\" is not",
        ),
        (
            &[(ID, "1"), (MIN, "-1"), (MAX, "3")],
            "SLURM_ARRAY_TASK_MIN=\"-1\"",
        ),
        (
            &[(ID, "1"), (MIN, "0"), (MAX, " 3")],
            "SLURM_ARRAY_TASK_MAX=\" 3\"",
        ),
        // a list (--array=1,2,7) is not a range
        (
            &[(ID, "2"), (MIN, "1"), (MAX, "7"), (COUNT, "3")],
            "COUNT=3 but the range 1-7 holds 7",
        ),
        (&[(ID, "3"), (MIN, "4"), (MAX, "2")], "are not a range"),
        (
            &[(ID, "9"), (MIN, "0"), (MAX, "3")],
            "SLURM_ARRAY_TASK_ID=9 is not an index",
        ),
        (
            &[(ID, "2"), (MIN, "3"), (MAX, "5")],
            "SLURM_ARRAY_TASK_ID=2 is not an index",
        ),
        (
            &[(ID, "2"), (MIN, "1"), (MAX, "9"), (STEP, "4")],
            "SLURM_ARRAY_TASK_ID=2 is not an index of the array 1-9:4",
        ),
        (
            &[(ID, "1"), (MIN, "1"), (MAX, "8"), (STEP, "4")],
            "are not a range",
        ),
        (&[(ID, "1"), (MIN, "1"), (MAX, "3"), (STEP, "0")], "STEP=0"),
        (&[(ID, "0"), (MIN, "0"), (COUNT, "0")], "COUNT=0"),
    ];
    for (vars, says) in cases {
        let e = slurm::shard(env(vars)).unwrap_err();
        assert!(e.starts_with("--shard auto: "), "{vars:?}: {e}");
        assert!(e.contains(says), "{vars:?}: {e}");
        assert!(!e.contains('\n'), "{vars:?}: {e}");
    }
    for bad in ["", "a b", "x/y", &"7".repeat(65), "12\n34"] {
        assert!(slurm::check_run_id(bad).is_err(), "{bad:?}");
    }
    assert_eq!(
        slurm::run_id(None, env(&[(slurm::ARRAY_JOB_ID, "4321")])),
        Ok(Some("4321".into()))
    );
    // --run-id wins over the array's job id (a task resubmitted for an earlier array)
    assert_eq!(
        slurm::run_id(Some("77"), env(&[(slurm::ARRAY_JOB_ID, "4321")])),
        Ok(Some("77".into()))
    );
    assert_eq!(slurm::run_id(None, env(&[])), Ok(None));
}

#[test]
fn shard_auto_outside_an_array_is_one_line_and_exit_2_and_writes_nothing() {
    let out = fresh("auto-outside");
    let o = out.to_str().unwrap();
    let bench = ["bench", "--suite", "extremes", "--filter", "tunneling"];
    let e = refused(
        with_env(&[])
            .args(bench)
            .args(["--shard", "auto", "--out", o])
            .output()
            .unwrap(),
        "bench outside an array",
    );
    assert!(
        e.starts_with("error: --shard auto: SLURM_ARRAY_TASK_ID is not set"),
        "{e}"
    );
    let e = refused(
        with_env(&[])
            .args(["tune", "stack", "--budget-ms", "1", "--shard", "auto"])
            .args(["--out", o])
            .output()
            .unwrap(),
        "tune outside an array",
    );
    assert!(e.contains("SLURM_ARRAY_TASK_ID is not set"), "{e}");
    // the array's variables, but not a range
    let list = [
        (slurm::TASK_ID, "2"),
        (slurm::TASK_MIN, "1"),
        (slurm::TASK_MAX, "7"),
        (slurm::TASK_COUNT, "3"),
    ];
    let e = refused(
        with_env(&list)
            .args(bench)
            .args(["--shard", "auto", "--out", o])
            .output()
            .unwrap(),
        "a list",
    );
    assert!(e.contains("not a list"), "{e}");
    // --run-id belongs to a shard or a merge
    let e = refused(
        with_env(&[])
            .args(bench)
            .args(["--run-id", "5", "--out", o])
            .output()
            .unwrap(),
        "--run-id alone",
    );
    assert!(e.contains("--run-id"), "{e}");
    assert!(!out.exists(), "refused before writing anything");
}

/// Runs one task of a (pretend) Slurm array `job` of `n` tasks numbered from 0:
/// `bench --suite extremes --filter tunneling --shard auto` into `out`.
fn array_task(job: &str, task: usize, n: usize, out: &Path) -> String {
    let (id, max, count) = (task.to_string(), (n - 1).to_string(), n.to_string());
    let vars = [
        (slurm::TASK_ID, id.as_str()),
        (slurm::TASK_MIN, "0"),
        (slurm::TASK_MAX, max.as_str()),
        (slurm::TASK_COUNT, count.as_str()),
        (slurm::ARRAY_JOB_ID, job),
    ];
    succeeded(
        with_env(&vars)
            .args(["bench", "--suite", "extremes", "--filter", "tunneling"])
            .args(["--shard", "auto", "--out"])
            .arg(out)
            .output()
            .unwrap(),
        &format!("job {job} task {task}"),
    )
}

fn merge(dir: &Path, out: &Path, run: Option<&str>) -> Output {
    let mut c = with_env(&[]);
    c.args(["bench", "--merge"]).arg(dir).arg("--out").arg(out);
    if let Some(r) = run {
        c.args(["--run-id", r]);
    }
    c.output().unwrap()
}

#[test]
fn array_tasks_merge_to_the_unsharded_table_and_two_arrays_in_one_folder_are_refused() {
    let whole = fresh("arr-whole");
    succeeded(
        with_env(&[])
            .args(["bench", "--suite", "extremes", "--filter", "tunneling"])
            .arg("--out")
            .arg(&whole)
            .output()
            .unwrap(),
        "unsharded",
    );
    let dir = fresh("arr-shards");
    for task in 0..3 {
        let said = array_task("1234", task, 3, &dir);
        let shard = format!("results.shard-{}-of-3.json", task + 1);
        assert!(said.contains(&shard), "{said}");
        let text = std::fs::read_to_string(dir.join(&shard)).unwrap();
        assert!(text.contains("\"run\": \"1234\""), "{text}");
    }
    let merged = fresh("arr-merged");
    succeeded(merge(&dir, &merged, Some("1234")), "merge");
    assert_eq!(
        std::fs::read(merged.join("stability.md")).unwrap(),
        std::fs::read(whole.join("stability.md")).unwrap(),
        "the array's merge writes the unsharded run's bytes"
    );
    // the merge told to expect another run refuses
    let e = refused(merge(&dir, &fresh("arr-m2"), Some("999")), "another run");
    assert!(e.contains("is a shard of run 1234, not of run 999"), "{e}");
    // a second array (job 1240) writes into the same folder; its task 1 fails, so the
    // first array's shard 2/3 is still there
    array_task("1240", 0, 3, &dir);
    array_task("1240", 2, 3, &dir);
    let e = refused(merge(&dir, &fresh("arr-m3"), None), "two arrays");
    assert!(
        e.contains("are shards of different runs: run 1234 vs run 1240"),
        "{e}"
    );
    let e = refused(merge(&dir, &fresh("arr-m4"), Some("1240")), "two arrays");
    assert!(
        e.contains("results.shard-2-of-3.json is a shard of run 1234, not of run 1240"),
        "{e}"
    );
    // a cancelled task in a folder of its own: the shard is named missing
    let own = fresh("arr-cancelled");
    array_task("1300", 0, 3, &own);
    array_task("1300", 2, 3, &own);
    let e = refused(merge(&own, &fresh("arr-m5"), Some("1300")), "cancelled");
    assert!(e.contains("shard 2/3 of run 1300 missing"), "{e}");
    // the missing task resubmitted as a job of its own (another job id), told its
    // shard and the array's run id, completes the run
    succeeded(
        with_env(&[(slurm::ARRAY_JOB_ID, "1377")])
            .args(["bench", "--suite", "extremes", "--filter", "tunneling"])
            .args(["--shard", "2/3", "--run-id", "1300", "--out"])
            .arg(&own)
            .output()
            .unwrap(),
        "resubmitted",
    );
    let m = fresh("arr-m6");
    succeeded(merge(&own, &m, Some("1300")), "completed");
    assert_eq!(
        std::fs::read(m.join("stability.md")).unwrap(),
        std::fs::read(whole.join("stability.md")).unwrap()
    );
}

#[cfg(unix)]
#[test]
fn a_rerun_task_replaces_its_shard_whole_or_leaves_it_as_it_was() {
    let dir = fresh("rerun");
    let vars = [
        (slurm::TASK_ID, "0"),
        (slurm::TASK_MIN, "0"),
        (slurm::TASK_MAX, "1"),
        (slurm::TASK_COUNT, "2"),
        (slurm::ARRAY_JOB_ID, "55"),
    ];
    let task = || {
        let mut c = with_env(&vars);
        c.args(["bench", "--suite", "quick", "--filter", "stack"])
            .args([
                "--steps",
                "5000",
                "--repeats",
                "1",
                "--shard",
                "auto",
                "--out",
            ])
            .arg(&dir);
        c
    };
    succeeded(task().output().unwrap(), "first run");
    let shard = dir.join("results.shard-1-of-2.json");
    let before = std::fs::read(&shard).unwrap();
    // Slurm stops a task with SIGTERM (scancel, a node going down, a preemption): the
    // rerun is stopped after some cases, and the shard file is the first run's, whole
    let mut child = task()
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // the rows go to a temporary file until the suite stops
    let partial = dir.join(format!(
        ".results.shard-1-of-2.partial.csv.{}.tmp",
        child.id()
    ));
    let t = std::time::Instant::now();
    while !std::fs::read_to_string(&partial).is_ok_and(|s| s.lines().count() >= 3)
        && t.elapsed().as_secs() < 60
        && child.try_wait().unwrap().is_none()
    {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    let status = child.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "stopped part way: {err}");
    assert!(err.contains("the shard file was not written"), "{err}");
    assert_eq!(
        std::fs::read(&shard).unwrap(),
        before,
        "the first run's shard, whole"
    );
    // a rerun that finishes puts its own file in place (its timings differ), and
    // leaves no temporary file
    succeeded(task().output().unwrap(), "rerun");
    let after = std::fs::read_to_string(&shard).unwrap();
    assert_ne!(
        after.as_bytes(),
        &before[..],
        "the rerun's timings are its own"
    );
    assert!(after.ends_with("}\n") && after.contains("\"run\": \"55\""));
    for e in std::fs::read_dir(&dir).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "temporary file {name} left");
        assert!(
            !name.ends_with(".partial.csv"),
            "{name} left by the finished rerun"
        );
    }
}

/// `tune.json` without what the clock decides: each setting's cost, the front and the
/// cheapest-close pick (both ranked by cost), and the note of how it ran.
fn clock_free(dir: &Path) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                for k in [
                    "ms_per_step",
                    "pareto",
                    "cheapest_within_10_percent",
                    "shards",
                    "run",
                ] {
                    m.remove(k);
                }
                m.values_mut().for_each(strip);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let text = std::fs::read_to_string(dir.join("tune.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    strip(&mut v);
    v
}

#[test]
fn tune_shards_merge_into_the_search_an_unsharded_tune_makes() {
    // a budget every setting fits, so that no timing decides which settings run or
    // win; penetration, whose values part the settings
    let args = [
        "tune",
        "stack",
        "--budget-ms",
        "1e9",
        "--metric",
        "penetration",
        "--steps",
        "60",
        "--rounds",
        "2",
    ];
    let whole = fresh("tune-whole");
    succeeded(
        with_env(&[])
            .args(args)
            .arg("--out")
            .arg(&whole)
            .output()
            .unwrap(),
        "unsharded",
    );
    let parts = fresh("tune-parts");
    for task in 0..3 {
        let id = task.to_string();
        let vars = [
            (slurm::TASK_ID, id.as_str()),
            (slurm::TASK_MIN, "0"),
            (slurm::TASK_MAX, "2"),
            (slurm::TASK_COUNT, "3"),
            (slurm::ARRAY_JOB_ID, "88"),
        ];
        let said = succeeded(
            with_env(&vars)
                .args(args)
                .args(["--shard", "auto", "--out"])
                .arg(&parts)
                .output()
                .unwrap(),
            "tune shard",
        );
        assert!(
            said.contains(&format!(
                "tune.shard-{}-of-3.json (shard {}/3: 12 of 36 settings)",
                task + 1,
                task + 1
            )),
            "{said}"
        );
    }
    assert!(!parts.join("tune.md").exists(), "a shard writes no report");
    let merged = fresh("tune-merged");
    let said = succeeded(
        with_env(&[])
            .args(["tune", "--merge"])
            .arg(&parts)
            .args(["--run-id", "88", "--out"])
            .arg(&merged)
            .output()
            .unwrap(),
        "tune merge",
    );
    assert!(
        said.contains("ran in 3 shards (`--shard`, run 88)"),
        "{said}"
    );
    let (a, b) = (clock_free(&whole), clock_free(&merged));
    // the pick is parted from every other setting by its score, not by its cost
    let tried = b["tried"].as_array().unwrap();
    let pick_score = b["pick"]["score"].as_f64().unwrap();
    let ties = tried
        .iter()
        .filter(|t| t["score"].as_f64() == Some(pick_score))
        .count();
    assert_eq!(ties, 1, "the pick's score is its own");
    assert!(tried.iter().any(|t| t["pass"] == "fine"), "a fine pass ran");
    assert_eq!(a, b, "the same settings, figures, scores and pick");
    assert_eq!(
        std::fs::read(whole.join("solver.toml")).unwrap(),
        std::fs::read(merged.join("solver.toml")).unwrap()
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(merged.join("tune.json")).unwrap()).unwrap();
    assert_eq!(
        (json["shards"].as_u64(), json["run"].as_str()),
        (Some(3), Some("88"))
    );
}

#[test]
fn tune_merge_refuses_a_missing_shard_another_run_or_another_search() {
    let parts = fresh("tune-bad");
    let shard = |i: usize, n: usize, steps: &str, extra: &[&str]| {
        let s = format!("{i}/{n}");
        succeeded(
            with_env(&[])
                .args(["tune", "pendulum", "--budget-ms", "1e9", "--steps", steps])
                .args(["--rounds", "1", "--shard", &s])
                .args(extra)
                .arg("--out")
                .arg(&parts)
                .output()
                .unwrap(),
            &s,
        )
    };
    let merge = |extra: &[&str]| {
        with_env(&[])
            .args(["tune", "--merge"])
            .arg(&parts)
            .args(extra)
            .output()
            .unwrap()
    };
    shard(1, 2, "10", &["--run-id", "a"]);
    let e = refused(merge(&[]), "missing");
    assert!(e.contains("shard 2/2 of run a missing"), "{e}");
    shard(2, 2, "10", &["--run-id", "b"]);
    let e = refused(merge(&[]), "two runs");
    assert!(e.contains("different runs: run b vs run a"), "{e}");
    let e = refused(merge(&["--run-id", "a"]), "two runs");
    assert!(
        e.contains("tune.shard-2-of-2.json is a shard of run b, not of run a"),
        "{e}"
    );
    shard(2, 2, "11", &["--run-id", "a"]);
    let e = refused(merge(&[]), "another search");
    assert!(e.contains("different searches: steps 11 vs 10"), "{e}");
    // a shard run refuses what only the merge does
    let e = refused(
        with_env(&[])
            .args([
                "tune",
                "pendulum",
                "--budget-ms",
                "1",
                "--shard",
                "1/2",
                "--json",
            ])
            .arg("--out")
            .arg(&parts)
            .output()
            .unwrap(),
        "--json",
    );
    assert!(e.contains("--json and --write go with the merge"), "{e}");
    let e = refused(
        with_env(&[])
            .args(["tune", "pendulum", "--budget-ms", "1", "--shard", "1/2"])
            .output()
            .unwrap(),
        "no --out",
    );
    assert!(e.contains("--shard needs --out"), "{e}");
}

#[test]
fn tune_merge_refuses_a_scene_file_changed_since_the_shards_ran() {
    let dir = fresh("tune-scene");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("s.toml");
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(repo.join("assets/scenes/pendulum.toml"), &scene).unwrap();
    let parts = dir.join("parts");
    let out = with_env(&[])
        .arg("tune")
        .arg(&scene)
        .args(["--budget-ms", "1e9", "--steps", "10", "--rounds", "1"])
        .args(["--shard", "1/1", "--out"])
        .arg(&parts)
        .output()
        .unwrap();
    succeeded(out, "shard");
    // the pendulum's gravity changes
    let text = std::fs::read_to_string(&scene).unwrap();
    let changed = text.replacen("gravity = [0.0, -9.81]", "gravity = [0.0, -3.0]", 1);
    assert_ne!(changed, text, "the scene file gives its gravity");
    std::fs::write(&scene, changed).unwrap();
    let e = refused(
        with_env(&[])
            .args(["tune", "--merge"])
            .arg(&parts)
            .output()
            .unwrap(),
        "changed scene",
    );
    assert!(e.contains("not the scene the shards ran"), "{e}");
    std::fs::write(&scene, text).unwrap();
    let said = succeeded(
        with_env(&[])
            .args(["tune", "--merge"])
            .arg(&parts)
            .output()
            .unwrap(),
        "restored scene",
    );
    assert!(said.contains("most accurate within the budget"), "{said}");
}
