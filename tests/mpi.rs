//! Data-parallel training over MPI end to end (cargo feature `mpi`; needs `mpirun`, Debian's
//! openmpi-bin): two processes on halves of each batch train as one process on the whole batch,
//! a resumed MPI run continues as the uninterrupted one, and a dead process ends the job.

mod common;

use burn::module::{Module, ModuleVisitor, Param};
use burn::prelude::*;
use common::{ok, starnet, write_tiny_car};
use starnet_train::checkpoint::load_model;
use starnet_train::config::load_config;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// `mpirun -np 2` of the starnet under test, allowed to run as root (CI containers).
fn mpirun(args: &[&str], cwd: &Path) -> Command {
    let mut c = Command::new("mpirun");
    c.args(["-np", "2", "--oversubscribe", env!("CARGO_BIN_EXE_starnet")])
        .args(args)
        .current_dir(cwd)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    c
}

fn run_mpi(args: &[&str], cwd: &Path) -> Output {
    mpirun(args, cwd).output().expect("mpirun (openmpi-bin) is installed")
}

/// The tiny car config, global batch 4, 20 steps (one per epoch), one compute thread.
fn config(dir: &Path) -> PathBuf {
    let base = write_tiny_car(dir, "tiny-car.toml");
    let p = dir.join("dp.toml");
    let text = format!(
        "base = \"{}\"\n[train]\nbatch_size = 4\nepochs = 20\nstep_threads = 1\neval_every = 0\n",
        base.display()
    );
    std::fs::write(&p, text).unwrap();
    p
}

/// Each step's loss terms and gradient norm from a run's log.
fn steps(run: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(run.join("log.jsonl")).unwrap();
    let keys = [
        "loss",
        "classification",
        "location",
        "dimension",
        "rotation",
        "grad_norm",
    ];
    text.lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v.get("loss").is_some())
        .map(|v| keys.iter().map(|k| v[k].as_f64().unwrap()).collect())
        .collect()
}

fn parameters(run: &Path, cfg_path: &Path) -> Vec<f32> {
    let cfg = load_config(cfg_path, &[]).unwrap();
    let dev = starnet_model::backend::default_device();
    let ckpt = run.join("checkpoints/step-00000020/model.bpk");
    let model = load_model(&ckpt, cfg.model_config().init(&dev)).unwrap();
    struct Collect(Vec<f32>);
    impl ModuleVisitor for Collect {
        fn visit_float<const D: usize>(&mut self, p: &Param<Tensor<D>>) {
            self.0.extend(p.val().into_data().iter::<f32>());
        }
    }
    let mut c = Collect(Vec::new());
    model.visit(&mut c);
    c.0
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1e-6)
}

#[test]
fn two_processes_train_as_one_and_resume_as_one() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let c = cfg.to_str().unwrap();
    ok(&starnet(&["train", "--config", c, "--run", "single"], dir.path()));
    // The MPI run stops after 10 steps and resumes with the same 2 processes.
    let dp = ["train", "--config", c, "--run", "dp", "--distributed", "mpi"];
    ok(&run_mpi(&[&dp[..], &["--max-steps", "10"]].concat(), dir.path()));
    let rest = run_mpi(&[&dp[..], &["--resume"]].concat(), dir.path());
    ok(&rest);
    let (one, two) = (steps(&dir.path().join("single")), steps(&dir.path().join("dp")));
    assert_eq!((one.len(), two.len()), (20, 20));
    for (step, (a, b)) in one.iter().zip(&two).enumerate() {
        for (a, b) in a.iter().zip(b) {
            assert!(relative(*a, *b) <= 1e-4, "step {}: {a} vs {b}", step + 1);
        }
    }
    let (a, b) = (
        parameters(&dir.path().join("single"), &cfg),
        parameters(&dir.path().join("dp"), &cfg),
    );
    let scale = a.iter().fold(0f32, |m, v| m.max(v.abs()));
    let worst = a.iter().zip(&b).fold(0f32, |m, (x, y)| m.max((x - y).abs()));
    assert!(worst <= 1e-4 * scale, "weights differ by {worst} (largest {scale})");
    // Only rank 0 reports the run.
    assert!(
        String::from_utf8_lossy(&rest.stdout)
            .matches("steps; run folder")
            .count()
            == 1
    );
}

/// The pids of the job's starnet processes by rank (from the environment mpirun gives them).
fn ranks(run: &str) -> Vec<(u32, String)> {
    let out = Command::new("pgrep").args(["-f", run]).output().unwrap();
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|pid| {
            let env = std::fs::read(format!("/proc/{pid}/environ")).ok()?;
            let env = String::from_utf8_lossy(&env).into_owned();
            let rank = env.split('\0').find_map(|v| v.strip_prefix("OMPI_COMM_WORLD_RANK="))?;
            Some((pid.parse().ok()?, rank.to_string()))
        })
        .collect()
}

#[test]
fn a_process_that_dies_ends_the_job_naming_its_rank() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let run = "dying-run";
    let args = [
        "train",
        "--config",
        cfg.to_str().unwrap(),
        "--run",
        run,
        "--distributed",
        "mpi",
    ];
    let mut job = mpirun(&args, dir.path())
        .args(["--set", "train.epochs=1000000"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let victim = loop {
        let log = dir.path().join(run).join("log.jsonl");
        let started = std::fs::read_to_string(&log).is_ok_and(|t| t.lines().count() > 2);
        if let Some((pid, _)) = ranks(run).into_iter().find(|(_, r)| r == "1").filter(|_| started) {
            break pid;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "the job did not start");
        std::thread::sleep(Duration::from_millis(200));
    };
    Command::new("kill").args(["-9", &victim.to_string()]).status().unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while job.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            job.kill().unwrap();
            panic!("the job hangs after rank 1 died");
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    let out = job.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("rank 1"), "{err}");
    assert!(ranks(run).is_empty(), "a process outlived the job");
}
