//! A run shared between processes gives the bits of one process: the shipped cases, run by
//! teams of 2, 3 and 4 members (threads standing in for MPI ranks, `hooke_core::team::Threads`)
//! and alone, end in the same state bit for bit on every member, and the writer's histories and
//! frames are byte for byte those of the lone run. The cases cover both kernels (CSR on random
//! lattices, the stencil on Ladd blocks), 2D and 3D, pre-cracks, breaking, rigid-body and
//! fragment contact, prescribed motion and loads. The same holds through MPI (`.ci/run` runs
//! `mpirun -np N hooke run` and compares with `tools/compare_runs.py`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use hooke_core::team::{Team, Threads};
use hooke_core::State;

struct Ended {
    state: State,
    broken: usize,
    out: PathBuf,
    held: Option<hooke_sim::Held>,
}

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hooke_team_{}_{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Run `case` (shipped, at `scale`, with `set` overrides) into `out`, as member `team` of a
/// team or alone.
fn run(case: &str, scale: f64, set: &[&str], out: &Path, team: Option<Arc<dyn Team>>) -> Ended {
    run_with(case, scale, set, out, team, false)
}

/// How a member of a team holds the body.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Hold {
    /// Whole, as one process does.
    Whole,
    /// Its piece, cut out of the whole body after the set-up (`RunOptions::pieces`).
    Pieces,
    /// Its piece, set up from its part alone (`hooke_case::prepare_parts`); resumed from the
    /// members' checkpoints in `out` if `resume`.
    Parts { resume: bool },
}

/// [`run`], each member holding only its piece of the body if `pieces`.
fn run_with(
    case: &str,
    scale: f64,
    set: &[&str],
    out: &Path,
    team: Option<Arc<dyn Team>>,
    pieces: bool,
) -> Ended {
    let hold = if pieces { Hold::Pieces } else { Hold::Whole };
    run_held(case, scale, set, out, team, hold)
}

/// A shipped case's path and text, and the overrides `set`.
fn shipped(case: &str, set: &[&str]) -> (PathBuf, String, Vec<hooke_case::Override>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../cases")
        .join(case);
    let text = std::fs::read_to_string(&path).unwrap();
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    (path, text, hooke_case::parse_overrides(&set).unwrap())
}

/// [`run`], each member holding the body as `hold` says.
fn run_held(
    case: &str,
    scale: f64,
    set: &[&str],
    out: &Path,
    team: Option<Arc<dyn Team>>,
    hold: Hold,
) -> Ended {
    let (path, text, overrides) = shipped(case, set);
    let (sim, mut opts) = match hold {
        Hold::Parts { .. } => {
            hooke_case::prepare_parts(&path, &text, scale, &overrides, team.clone()).unwrap()
        }
        _ => hooke_case::prepare(&path, &text, scale, &overrides).unwrap(),
    };
    opts.out = out.to_path_buf();
    opts.name = "run".into();
    opts.team = team;
    opts.pieces = hold != Hold::Whole;
    if hold == (Hold::Parts { resume: true }) {
        opts.resume = Some(out.join("run.ckpt"));
    }
    let (_, sim) = hooke_sim::run_keeping(sim, opts, &mut hooke_sim::Silent).unwrap();
    Ended {
        broken: sim.broken().0,
        state: sim.state,
        out: out.to_path_buf(),
        held: sim.held,
    }
}

fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

fn same_state(a: &State, b: &State) -> bool {
    same_bits(a.u.as_flat(), b.u.as_flat())
        && same_bits(a.v.as_flat(), b.v.as_flat())
        && a.alive() == b.alive()
        && same_bits(&a.weights(), &b.weights())
        && a.step == b.step
        && a.time.to_bits() == b.time.to_bits()
}

/// The files a run writes whose bytes depend only on the physics (not run.json, whose clock
/// and command line differ).
fn physics_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            p.is_file() && name != "run.json"
        })
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().to_string(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

/// The members of a team of `size` (threads standing in for ranks), each running `go`.
fn members<T: Send>(size: usize, go: impl Fn(Arc<dyn Team>) -> T + Sync) -> Vec<T> {
    std::thread::scope(|s| {
        let go = &go;
        let handles: Vec<_> = Threads::team(size)
            .into_iter()
            .map(|t| s.spawn(move || go(Arc::new(t))))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// `a` and `b` are the same files (names and bytes).
fn assert_same_files(a: &[(String, Vec<u8>)], b: &[(String, Vec<u8>)], what: &str) {
    let names = |f: &[(String, Vec<u8>)]| f.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
    assert_eq!(names(a), names(b), "{what}");
    for ((name, x), (_, y)) in a.iter().zip(b) {
        assert!(x == y, "{what}: {name} differs");
    }
}

fn check(case: &str, scale: f64, set: &[&str], sizes: &[usize]) {
    // The folders are named by the case and its overrides: two tests of one case run side by
    // side (the softening test is the mode-I plate too) and must not share a folder.
    let tag = format!(
        "{}_{:016x}",
        case.trim_end_matches(".toml"),
        set.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, s| s
            .bytes()
            .fold(h, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3)))
    );
    let alone = run(case, scale, set, &scratch(&format!("{tag}_1")), None);
    let reference = physics_files(&alone.out);
    // Each member must own nodes: whole chunks of nodes are what is shared.
    let chunks = alone.state.u.len().div_ceil(hooke_core::kernel::CHUNK);
    assert!(
        chunks >= *sizes.iter().max().unwrap(),
        "{case}: {chunks} chunks"
    );
    eprintln!(
        "{case}: {} nodes ({chunks} chunks), {} springs broken, {} steps",
        alone.state.u.len(),
        alone.broken,
        alone.state.step
    );
    assert!(reference.iter().any(|(n, _)| n.ends_with(".vtu")));
    assert!(reference.iter().any(|(n, _)| n.ends_with(".ckpt")));
    for &size in sizes {
        let out = scratch(&format!("{tag}_{size}"));
        let members = members(size, |t| run(case, scale, set, &out, Some(t)));
        for (r, m) in members.iter().enumerate() {
            assert!(
                same_state(&alone.state, &m.state),
                "{case}: member {r} of {size} ends in another state than the lone run"
            );
            assert_eq!(alone.broken, m.broken, "{case}: broken springs, member {r}");
        }
        // Frames come in pieces, one per member, listed by a .pvtu each (their contents are
        // compared through the readers in CI: tools/mpi_check.sh); everything else byte for byte.
        let is_frame = |n: &str| {
            n.starts_with("run_")
                && n[4..]
                    .split(['_', '.'])
                    .next()
                    .is_some_and(|s| s.len() == 6 && s.bytes().all(|b| b.is_ascii_digit()))
        };
        let written = physics_files(&out);
        let frames: Vec<&String> = reference
            .iter()
            .map(|f| &f.0)
            .filter(|n| is_frame(n))
            .collect();
        assert!(!frames.is_empty(), "{case}: no frames");
        for f in &frames {
            let stem = f.trim_end_matches(".vtu");
            assert!(
                written.iter().any(|w| w.0 == format!("{stem}.pvtu")),
                "{case}: {stem}.pvtu"
            );
            for r in 0..size {
                let piece = format!("{stem}_{r}.vtu");
                assert!(
                    written.iter().any(|w| w.0 == piece),
                    "{case}: {piece} missing"
                );
            }
        }
        let pvd = String::from_utf8(written.iter().find(|w| w.0 == "run.pvd").unwrap().1.clone())
            .unwrap();
        assert_eq!(pvd.matches(".pvtu").count(), frames.len(), "{case}: {pvd}");
        let rest = |f: &[(String, Vec<u8>)]| {
            f.iter()
                .filter(|x| !is_frame(&x.0) && x.0 != "run.pvd")
                .cloned()
                .collect::<Vec<_>>()
        };
        assert_same_files(
            &rest(&reference),
            &rest(&written),
            &format!("{case}, {size} members"),
        );
        let _ = std::fs::remove_dir_all(&out);
    }
    let _ = std::fs::remove_dir_all(&alone.out);
}

/// Every member of a team of `size` whose members hold pieces (`how` says how they got them)
/// ended with the lone run's state at its own nodes and its broken springs, and wrote its own
/// checkpoint into `out`; their own nodes cover the body.
fn assert_members_end_alone(case: &str, how: &str, alone: &Ended, members: &[Ended], out: &Path) {
    let (n, size) = (alone.state.u.len(), members.len());
    let mut seen = 0;
    for (r, m) in members.iter().enumerate() {
        let at = format!("{case}: member {r} of {size} {how}");
        let held = m.held.as_ref().expect("a piece");
        // Fewer than the body's nodes, unless it owns them all (the others own none) or the
        // body is smaller than the dummies that align a piece on a chunk.
        assert!(
            m.state.u.len() < n || held.own.len() == n || n <= hooke_core::kernel::CHUNK,
            "{at}: holds {} of {n} nodes",
            m.state.u.len()
        );
        assert_eq!(m.broken, alone.broken, "{at}: broken springs");
        assert_eq!(m.state.step, alone.state.step, "{at}");
        for (k, i) in held.own.clone().enumerate() {
            let g = held.first + k;
            for c in 0..3 {
                let (a, b) = (&alone.state, &m.state);
                assert_eq!(
                    b.u.comp(c)[i].to_bits(),
                    a.u.comp(c)[g].to_bits(),
                    "{at}: u {g}"
                );
                assert_eq!(
                    b.v.comp(c)[i].to_bits(),
                    a.v.comp(c)[g].to_bits(),
                    "{at}: v {g}"
                );
            }
        }
        seen += held.own.len();
        let ckpt = out.join(format!("run.{r}of{size}.ckpt"));
        assert!(ckpt.exists(), "{at}: {}", ckpt.display());
    }
    assert_eq!(seen, n, "{case}: the members' own nodes cover the body");
}

/// The energy and reaction histories in `written` are the lone run's (`reference`), byte for
/// byte.
fn assert_histories(case: &str, reference: &[(String, Vec<u8>)], written: &[(String, Vec<u8>)]) {
    for name in ["run_energy.csv", "run_reactions.csv"] {
        let lone = reference.iter().find(|x| x.0 == name);
        let mine = written.iter().find(|x| x.0 == name);
        assert_eq!(lone.is_some(), mine.is_some(), "{case}: {name}");
        if let (Some(x), Some(y)) = (lone, mine) {
            assert!(x.1 == y.1, "{case}: {name} differs from the lone run's");
        }
    }
}

/// Teams of `sizes` whose members each hold only their piece of the body (`RunOptions::
/// pieces`) end with the lone run's state at their own nodes and its broken springs, write
/// its histories byte for byte, and the frames' pieces of members that hold the whole body,
/// byte for byte; each member writes its own checkpoint.
fn check_pieces(case: &str, scale: f64, set: &[&str], sizes: &[usize]) {
    let tag = format!("pieces_{}", case.trim_end_matches(".toml"));
    let alone = run(case, scale, set, &scratch(&format!("{tag}_1")), None);
    let reference = physics_files(&alone.out);
    let n = alone.state.u.len();
    eprintln!(
        "{case} on pieces: {n} nodes, {} springs broken",
        alone.broken
    );
    assert!(alone.broken > 0, "{case}: nothing breaks");
    for &size in sizes {
        let team_run = |pieces: bool| -> (PathBuf, Vec<Ended>) {
            let out = scratch(&format!("{tag}_{size}_{pieces}"));
            let members = members(size, |t| run_with(case, scale, set, &out, Some(t), pieces));
            (out, members)
        };
        let (whole_out, _) = team_run(false);
        let (out, members) = team_run(true);
        assert_members_end_alone(case, "on pieces", &alone, &members, &out);
        let written = physics_files(&out);
        let whole = physics_files(&whole_out);
        // Everything but the checkpoints as the members holding the whole body wrote it.
        let frames_of = |f: &[(String, Vec<u8>)]| {
            f.iter()
                .filter(|x| !x.0.ends_with(".ckpt"))
                .cloned()
                .collect::<Vec<_>>()
        };
        assert_same_files(
            &frames_of(&whole),
            &frames_of(&written),
            &format!("{case} on pieces, {size} members"),
        );
        // The histories as the lone run wrote them.
        assert_histories(case, &reference, &written);
        let _ = std::fs::remove_dir_all(&out);
        let _ = std::fs::remove_dir_all(&whole_out);
    }
    let _ = std::fs::remove_dir_all(&alone.out);
}

/// Teams of `sizes` whose members set the body up from their parts alone (no member builds
/// it whole) end with the lone run's state at their own nodes and its broken springs at
/// `end` (s), and write its histories byte for byte; each member writes its own checkpoint.
/// Run to `end / 2` and resumed from those checkpoints, they end the same. The frames' pieces
/// split the body elsewhere than a whole set-up's (`tools/check_pieces.py` compares them node
/// for node in CI).
fn check_parts(case: &str, scale: f64, set: &[&str], end: f64, sizes: &[usize]) {
    let tag = format!("parts_{}", case.trim_end_matches(".toml"));
    let to = |t: f64| format!("solver.end_time={t:e}");
    let (full, half) = (to(end), to(0.5 * end));
    fn with<'a>(set: &[&'a str], t: &'a str) -> Vec<&'a str> {
        set.iter().copied().chain([t]).collect()
    }
    let alone = run(
        case,
        scale,
        &with(set, &full),
        &scratch(&format!("{tag}_1")),
        None,
    );
    let reference = physics_files(&alone.out);
    eprintln!(
        "{case} from parts: {} nodes, {} springs broken",
        alone.state.u.len(),
        alone.broken
    );
    assert!(alone.broken > 0, "{case}: nothing breaks");
    for &size in sizes {
        for resumed in [false, true] {
            let out = scratch(&format!("{tag}_{size}_{resumed}"));
            let go = |set: &[&str], resume: bool| {
                members(size, |t| {
                    run_held(case, scale, set, &out, Some(t), Hold::Parts { resume })
                })
            };
            if resumed {
                go(&with(set, &half), false);
            }
            let members = go(&with(set, &full), resumed);
            let how = if resumed {
                "from parts, resumed"
            } else {
                "from parts"
            };
            assert_members_end_alone(case, how, &alone, &members, &out);
            assert_histories(case, &reference, &physics_files(&out));
            let _ = std::fs::remove_dir_all(&out);
        }
    }
    let _ = std::fs::remove_dir_all(&alone.out);
}

/// A random plate on a jittered grid with a pre-crack, breaking springs between grips that
/// never break, a notched 3D bar under a traction, and Kalthoff-Winkler's plate (a rigid
/// projectile, fragment contact), set up from parts on teams of 2 and 3.
#[test]
#[ignore = "slow (minutes here); CI runs --pieces and --parts under real MPI on shipped cases (tools/mpi_check.sh); run with --ignored before changing the team code"]
fn parts_run_with_the_bits_of_one_process() {
    check_parts(
        "mode1_plate.toml",
        1.5,
        &[
            "lattice.sampler=\"jitter\"",
            "output.every=25e-6",
            "output.reactions_every=5e-6",
        ],
        50e-6,
        &[2, 3],
    );
    // 3D: a traction, a face held, a polygonal pre-crack.
    check_parts(
        "notched_bar_3d.toml",
        1.3,
        &["output.every=5e-6"],
        10e-6,
        &[2, 3],
    );
    // A rigid projectile placed by its start gap (the nearest node found across the members)
    // and fragment contact across the cracks, long enough for crack faces to meet.
    check_parts(
        "kalthoff_winkler.toml",
        0.3,
        &["lattice.sampler=\"jitter\"", "output.every=30e-6"],
        60e-6,
        &[2, 3],
    );
}

/// An anisotropic random plate (a transverse material: spring stiffness and dispersion
/// weight by direction, a direction-dependent critical stretch) set up from parts: every
/// member calibrates the direction functions alike (here read from one disk cache).
#[test]
#[ignore = "slow (minutes here); CI runs --pieces and --parts under real MPI on shipped cases (tools/mpi_check.sh); run with --ignored before changing the team code"]
fn anisotropic_parts_run_with_the_bits_of_one_process() {
    let cache = scratch("calibrations");
    hooke_core::random::anisotropic::set_cache_dir(Some(cache.clone()));
    check_parts(
        "fibre_notch_plate.toml",
        1.0,
        &["lattice.sampler=\"jitter\"", "output.every=45e-6"],
        90e-6,
        &[2],
    );
    let _ = std::fs::remove_dir_all(&cache);
}

/// Members holding only their pieces of a random plate with a pre-crack, breaking springs
/// through the stretch screen inside the step (the row or CSR kernel), of Kalthoff-Winkler
/// (a rigid projectile, fragment contact across the crack), of the anisotropic random plate
/// (levers, a direction-dependent stretch), and of the plate with softening springs (damage
/// weights; the kernel handed to the general one at the first damage).
#[test]
#[ignore = "slow (minutes here); CI runs --pieces and --parts under real MPI on shipped cases (tools/mpi_check.sh); run with --ignored before changing the team code"]
fn pieces_run_with_the_bits_of_one_process() {
    // Reactions between frames too (the prescribed nodes' forces from their owners).
    check_pieces(
        "mode1_plate.toml",
        1.5,
        &[
            "solver.end_time=50e-6",
            "output.every=25e-6",
            "output.reactions_every=5e-6",
        ],
        &[2, 3],
    );
    // Long enough for crack faces to meet: fragment contact pairs nodes of different ranks.
    check_pieces(
        "kalthoff_winkler.toml",
        0.3,
        &["solver.end_time=60e-6", "output.every=20e-6"],
        &[2, 3],
    );
    check_pieces(
        "fibre_notch_plate.toml",
        1.0,
        &["solver.end_time=90e-6", "output.every=30e-6"],
        &[3],
    );
    check_pieces(
        "mode1_plate.toml",
        1.5,
        &[
            "solver.end_time=50e-6",
            "output.every=25e-6",
            "material.criterion=\"softening\"",
            "material.softening=\"bilinear\"",
            "material.tensile_strength=5e6",
        ],
        &[2],
    );
}

/// A random plate with a pre-crack, loaded until springs break (CSR kernel, screened criterion).
#[test]
fn mode_one_plate_is_bit_identical_for_any_team() {
    check(
        "mode1_plate.toml",
        1.5,
        &["solver.end_time=50e-6", "output.every=25e-6"],
        &[2, 3, 4],
    );
}

/// A Ladd block hit by a rigid sphere, breaking, with fragment contact (stencil kernel, 3D).
#[test]
fn sphere_impact_is_bit_identical_for_any_team() {
    check(
        "sphere_impact_glass.toml",
        0.8,
        &["solver.end_time=8e-6", "output.every=4e-6"],
        &[2, 3],
    );
}

/// The glass plate on the hexagonal lattice (its stencil kernel, a plate: z left alone),
/// breaking.
#[test]
fn hexagonal_glass_plate_is_bit_identical_for_any_team() {
    check(
        "glass_branching.toml",
        0.5,
        &["solver.end_time=30e-6", "output.every=15e-6"],
        &[2, 3],
    );
}

/// Kalthoff-Winkler: a projectile, notches and running cracks on a random plate.
#[test]
fn kalthoff_winkler_is_bit_identical_for_any_team() {
    check(
        "kalthoff_winkler.toml",
        0.3,
        &["solver.end_time=20e-6", "output.every=10e-6"],
        &[2, 3],
    );
}

/// The Brazilian disk between two kinematic platens, and the compression block (stencil kernel,
/// prescribed motion, no fracture).
#[test]
fn platens_and_blocks_are_bit_identical_for_any_team() {
    check(
        "brazilian_disk.toml",
        1.0,
        &["solver.end_time=40e-6", "output.every=20e-6"],
        &[2],
    );
    check(
        "compression_block.toml",
        1.0,
        &["solver.end_time=10e-6", "output.every=5e-6"],
        &[2, 3],
    );
}

/// Softening springs (damage weights in the pools and normalisers, the stencil handing the
/// block to the general kernel at the first damage): the sphere impact on the Ladd block and the
/// random mode-I plate, bilinear.
#[test]
fn softening_is_bit_identical_for_any_team() {
    check(
        "sphere_impact_glass.toml",
        0.8,
        &[
            "solver.end_time=8e-6",
            "output.every=4e-6",
            "material.criterion=\"softening\"",
            "material.tensile_strength=5e6",
        ],
        &[2, 3],
    );
    check(
        "mode1_plate.toml",
        1.5,
        &[
            "solver.end_time=50e-6",
            "output.every=25e-6",
            "material.criterion=\"softening\"",
            "material.softening=\"bilinear\"",
            "material.tensile_strength=5e6",
        ],
        &[3],
    );
}

/// The spring-energy criterion, which has no stretch screen: its decisions run after the step
/// on each member's own springs, and the members trade what they found. The hexagonal glass
/// plate (stencil) and the sphere impact on the Ladd block (3D, fragment contact).
#[test]
fn energy_criterion_is_bit_identical_for_any_team() {
    check(
        "glass_branching.toml",
        0.5,
        &[
            "solver.end_time=30e-6",
            "output.every=15e-6",
            "material.criterion=\"energy\"",
        ],
        &[2, 3],
    );
    check(
        "sphere_impact_glass.toml",
        0.8,
        &[
            "solver.end_time=8e-6",
            "output.every=4e-6",
            "material.criterion=\"energy\"",
        ],
        &[2, 3],
    );
}

/// A transversely isotropic material (direction-weighted levers on the general kernel).
#[test]
fn transverse_material_is_bit_identical_for_any_team() {
    check(
        "fibre_block.toml",
        1.0,
        &["solver.end_time=10e-6", "output.every=5e-6"],
        &[2, 3],
    );
}

/// An anisotropic random2d plate (a calibrated direction design, its levers on the row kernel)
/// with a direction-dependent stretch breaking springs from its notch.
#[test]
fn anisotropic_plate_is_bit_identical_for_any_team() {
    check(
        "fibre_notch_plate.toml",
        1.0,
        &["solver.end_time=90e-6", "output.every=30e-6"],
        &[2, 3],
    );
}

/// Quasi-static runs are refused with the reason when shared.
#[test]
fn quasi_static_runs_are_refused_in_a_team() {
    let text = include_str!("data/quasi_static.toml");
    let path = Path::new("qs.toml");
    let r = std::thread::scope(|s| {
        let handles: Vec<_> = Threads::team(2)
            .into_iter()
            .map(|t| {
                s.spawn(move || {
                    let (sim, mut opts) = hooke_case::prepare(path, text, 1.0, &[]).unwrap();
                    opts.out = scratch("qs");
                    opts.name = "qs".into();
                    opts.team = Some(Arc::new(t));
                    hooke_sim::run(sim, opts, &mut hooke_sim::Silent)
                        .err()
                        .map(|e| e.to_string())
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap())
            .collect::<Vec<_>>()
    });
    for e in r {
        let e = e.expect("refused");
        assert!(
            e.contains("quasi-static") && e.contains("one process"),
            "{e}"
        );
    }
}

/// An instability stops every member with the lone run's message: each member checks only
/// the nodes it owns, and the one that finds a failure makes all of them look at the whole.
#[test]
fn an_instability_stops_every_member_alike() {
    let text = include_str!("data/unstable.toml");
    let path = Path::new("unstable.toml");
    let go = |tag: String, team: Option<Arc<dyn Team>>| {
        let (sim, mut opts) = hooke_case::prepare(path, text, 1.0, &[]).unwrap();
        assert!(sim.body.nodes() > 2 * hooke_core::kernel::CHUNK);
        opts.out = scratch(&tag);
        opts.name = "unstable".into();
        opts.team = team;
        hooke_sim::run(sim, opts, &mut hooke_sim::Silent)
            .err()
            .map(|e| e.to_string())
            .expect("unstable")
    };
    let alone = go("unstable_1".into(), None);
    let _ = std::fs::remove_dir_all(scratch("unstable_1"));
    assert!(
        alone.contains("step 64") && alone.contains("thousand times"),
        "{alone}"
    );
    for size in [2, 3] {
        let members = std::thread::scope(|s| {
            let handles: Vec<_> = Threads::team(size)
                .into_iter()
                .map(|t| s.spawn(move || go(format!("unstable_{size}"), Some(Arc::new(t)))))
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap())
                .collect::<Vec<_>>()
        });
        for (r, e) in members.iter().enumerate() {
            assert_eq!(e, &alone, "member {r} of {size}");
        }
        let _ = std::fs::remove_dir_all(scratch(&format!("unstable_{size}")));
    }
}

/// The sphere impact to its end, where fragments fly apart: the fragment lists' rebuilds, which
/// each member makes from its own nodes and the positions the others send, find the pairs one
/// process finds (a rebuild reading other members' stale positions breaks this test, not the
/// shorter one above).
#[test]
fn fragment_contact_rebuilds_alike_in_a_team() {
    check(
        "sphere_impact_glass.toml",
        0.8,
        &["output.every=10e-6"],
        &[3],
    );
}

/// What a set-up from parts cannot do is refused on every member alike, naming the key and
/// the reason, before any member builds anything.
#[test]
fn parts_refuse_what_they_cannot_build_with_the_reason() {
    for (case, set, key, why) in [
        ("mode1_plate.toml", vec![], "lattice.sampler", "jitter"),
        (
            "glass_branching.toml",
            vec![],
            "lattice.kind",
            "random lattices",
        ),
        (
            "mode1_plate.toml",
            vec!["lattice.sampler=\"jitter\"", "output.format=[\"hdf5\"]"],
            "output.format",
            "HDF5",
        ),
    ] {
        let (path, text, overrides) = shipped(case, &set);
        let errors = members(2, |t| {
            hooke_case::prepare_parts(&path, &text, 0.5, &overrides, Some(t))
                .err()
                .map(|e| e.to_string())
        });
        for e in errors {
            let e = e.unwrap_or_else(|| panic!("{case}: not refused"));
            assert!(e.contains(key) && e.contains(why), "{case}: {e}");
            assert!(e.contains("run without --parts"), "{case}: {e}");
        }
    }
}

/// Every split of a small case runs (issue "A failed rank never hangs a job"): bodies of one
/// or two chunks on teams of up to 5 members, so that members own no node before and after the
/// body's short last chunk, or fewer than 64 nodes, holding the whole body, on pieces, and set
/// up from parts (fresh and resumed). The runs break springs, write frames and checkpoints, and
/// have prescribed and loaded nodes on other members than most. Each member must end with the
/// lone run's bits (`tests/splits.rs` covers every kernel at exact node counts).
#[test]
fn every_split_of_a_small_case_runs() {
    // The mode-I plate at a quarter scale: 425 nodes, one chunk; members 0 and 2 of 3 own none.
    check_pieces("mode1_plate.toml", 0.25, &[], &[3, 5]);
    // A jittered random plate of about 1.1 chunks (its last member owns the short chunk's
    // nodes) and the notched 3D bar at half scale, from parts.
    check_parts(
        "mode1_plate.toml",
        0.65,
        &["lattice.sampler=\"jitter\"", "output.every=20e-6"],
        40e-6,
        &[2, 4, 5],
    );
    check_parts(
        "notched_bar_3d.toml",
        0.5,
        &["output.every=5e-6"],
        10e-6,
        &[3, 5],
    );
}
