//! tinybvh (C++) as a peer in the same rounds as ours: a child process built from
//! `crates/bench/peers/tinybvh/tinybvh_peer.cpp`, driven one command per line over its stdin and stdout.
//! accel-bench's `build`, `rays` and `meshes` suites run it only when the environment variable
//! `TINYBVH_PEER` names the binary that `crates/bench/peers/tinybvh/tinybvh.sh` prints; without it they
//! time the Rust contenders alone and say so in a note.
//!
//! A child process rather than a linked library: tinybvh is one C++ header, and linking it
//! would give the accel crate a build script and a C++ compiler on every build. The process
//! boundary is outside every timing: each command times itself in the child.

use glam::Vec3A;
use spatial_accel::Triangle;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

/// A running tinybvh peer and the folder of the files it reads.
pub struct TinyBvh {
    child: Child,
    input: ChildStdin,
    output: BufReader<ChildStdout>,
    dir: PathBuf,
    /// tinybvh's version, as the peer reports it.
    pub version: String,
}

/// One ray set loaded into the peer.
#[derive(Clone, Copy)]
pub struct PeerRays(usize);

fn write_floats(path: &Path, count: usize, floats: impl Iterator<Item = f32>) {
    let mut bytes = (count as u32).to_le_bytes().to_vec();
    for f in floats {
        bytes.extend_from_slice(&f.to_le_bytes());
    }
    std::fs::write(path, bytes).expect("the peer's input files are writable");
}

impl TinyBvh {
    /// Starts the peer named by `TINYBVH_PEER` over `tris`; `None` when the variable is unset.
    /// Panics (this is a benchmark) when the binary cannot be started.
    pub fn from_env(tris: &[Triangle]) -> Option<Self> {
        let binary = std::env::var_os("TINYBVH_PEER")?;
        let dir = std::env::temp_dir().join(format!("accel-tinybvh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a temporary folder");
        let scene = dir.join("scene.bin");
        write_floats(
            &scene,
            tris.len(),
            tris.iter()
                .flat_map(|t| t.vertices)
                .flat_map(|v| [v.x, v.y, v.z, 0.0]),
        );
        let mut child = Command::new(&binary)
            .arg(&scene)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start TINYBVH_PEER {binary:?}: {e}"));
        let input = child.stdin.take().expect("piped stdin");
        let output = BufReader::new(child.stdout.take().expect("piped stdout"));
        let mut peer = Self {
            child,
            input,
            output,
            dir,
            version: String::new(),
        };
        let ready = peer.read_line();
        peer.version = ready
            .strip_prefix("ready ")
            .unwrap_or_else(|| panic!("tinybvh peer did not start: {ready:?}"))
            .to_owned();
        Some(peer)
    }

    fn read_line(&mut self) -> String {
        let mut line = String::new();
        self.output.read_line(&mut line).expect("the peer answers");
        let line = line.trim().to_owned();
        assert!(
            !line.is_empty() && !line.starts_with("error"),
            "tinybvh peer: {line:?}"
        );
        line
    }

    fn ask(&mut self, command: &str) -> String {
        writeln!(self.input, "{command}").expect("the peer reads commands");
        self.input.flush().expect("the peer reads commands");
        self.read_line()
    }

    fn numbers(&mut self, command: &str) -> Vec<f64> {
        self.ask(command)
            .split_whitespace()
            .map(|x| x.parse().expect("the peer answers numbers"))
            .collect()
    }

    /// One single-threaded `BVH::BuildAVX` (binned SAH) over the triangles: seconds, and
    /// tinybvh's own SAH cost of the tree (its cost constants, not ours).
    pub fn build_avx(&mut self) -> (f64, f64) {
        let v = self.numbers("build");
        (v[0], v[1])
    }

    /// [`build_avx`](Self::build_avx) into one tree kept in the peer, whose buffers each
    /// rebuild reuses (a game's rebuild every frame): seconds.
    pub fn rebuild_avx(&mut self) -> f64 {
        self.numbers("rebuild")[0]
    }

    /// Builds and keeps the ray layout `name` (`bvh8_cpu`, `bvh4_cpu`, `bvh8_cpu_hq`: the
    /// 8-wide layout over tinybvh's default build, 4-wide, 8-wide over its SBVH); seconds.
    pub fn layout(&mut self, name: &str) -> f64 {
        self.numbers(&format!("layout {name}"))[0]
    }

    /// Loads rays `(origin, unit direction, t_max)` for closest-hit or any-hit tracing.
    pub fn rays(&mut self, name: &str, rays: &[(Vec3A, Vec3A, f32)], any_hit: bool) -> PeerRays {
        let path = self.dir.join(format!("{name}.bin"));
        write_floats(
            &path,
            rays.len(),
            rays.iter()
                .flat_map(|&(o, d, t)| [o.x, o.y, o.z, d.x, d.y, d.z, t.min(f32::MAX), 0.0]),
        );
        let id = self.numbers(&format!("rays {} {}", path.display(), any_hit as u8))[0];
        PeerRays(id as usize)
    }

    /// Traces every ray of `set` once in `layout`: rays per second.
    pub fn trace(&mut self, set: PeerRays, layout: &str) -> f64 {
        self.numbers(&format!("trace {} {layout}", set.0))[0]
    }

    /// The first `n` answers of `set` in `layout`: the closest `t` (or `Some(0.0)` when an any-hit ray is
    /// blocked), `None` for a miss.
    pub fn hits(&mut self, set: PeerRays, n: usize, layout: &str) -> Vec<Option<f32>> {
        self.numbers(&format!("hits {} {n} {layout}", set.0))
            .into_iter()
            .map(|t| (t >= 0.0).then_some(t as f32))
            .collect()
    }
}

impl Drop for TinyBvh {
    fn drop(&mut self) {
        let _ = writeln!(self.input, "quit");
        let _ = self.input.flush();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
