//! SIGINT or SIGTERM during the write of a render leaves no `.irr-*.tmp`
//! behind. The test runs a child copy of this test binary that writes a large image again and
//! again with the handler `cargo xtask render` installs, signals it while a temporary file is
//! being written, and looks at the folder afterwards.

use glam::Vec3;
use irr_render::{Image, remove_partial_outputs_on_signals, write_exr_and_png};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

const CHILD_DIR: &str = "IRR_SIGNAL_TEST_DIR";

fn temporaries(dir: &Path) -> Vec<(PathBuf, u64)> {
    std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .filter(|e| e.file_name().to_string_lossy().starts_with(".irr-"))
                .map(|e| (e.path(), e.metadata().map(|m| m.len()).unwrap_or(0)))
                .collect()
        })
        .unwrap_or_default()
}

/// The child: writes a 1024×1024 image of noise (slow to compress) over and over for at most
/// 60 s, with the signal handler installed. Run only by the parent test below.
#[test]
#[ignore = "run by writing_is_interrupted_without_leftovers in a child process"]
fn interrupted_write_child() {
    let Ok(dir) = std::env::var(CHILD_DIR) else {
        return;
    };
    remove_partial_outputs_on_signals().unwrap_or_else(|e| panic!("{e}"));
    let mut image = Image::new(1024, 1024);
    let mut state = 1u32;
    for y in 0..1024 {
        for x in 0..1024 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            image.set(x, y, Vec3::splat(state as f32 / u32::MAX as f32));
        }
    }
    let out = Path::new(&dir).join("render.exr");
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(60) {
        write_exr_and_png(&image, &out, 0.0).unwrap_or_else(|e| panic!("{e}"));
    }
}

fn spawn_child(dir: &Path) -> Child {
    let exe = std::env::current_exe().unwrap_or_else(|e| panic!("{e}"));
    Command::new(exe)
        .args([
            "signals::interrupted_write_child",
            "--exact",
            "--ignored",
            "--test-threads=1",
        ])
        .env(CHILD_DIR, dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("{e}"))
}

#[cfg(unix)]
#[test]
fn writing_is_interrupted_without_leftovers() {
    for signal in ["INT", "TERM"] {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let mut child = spawn_child(dir.path());
        // Wait until a temporary file with content exists (the EXR or PNG being written; the
        // empty one that checks the folder does not count).
        let started = Instant::now();
        let seen = loop {
            if temporaries(dir.path()).iter().any(|(_, len)| *len > 0) {
                break true;
            }
            if started.elapsed() > Duration::from_secs(50) {
                break false;
            }
            std::thread::sleep(Duration::from_micros(200));
        };
        let killed = Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status()
            .unwrap_or_else(|e| panic!("kill: {e}"));
        let status = child.wait().unwrap_or_else(|e| panic!("{e}"));
        assert!(seen, "SIG{signal}: no temporary file appeared within 50 s");
        assert!(killed.success());
        assert_eq!(
            status.code(),
            Some(130),
            "SIG{signal}: the child did not exit through the handler: {status}"
        );
        let left = temporaries(dir.path());
        assert!(left.is_empty(), "SIG{signal} left {left:?}");
    }
}
