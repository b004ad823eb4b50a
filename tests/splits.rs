//! Every split of a body between ranks runs, with the bits of one process (issue "A failed rank
//! never hangs a job").
//!
//! Ranks own whole chunks of `hooke_core::kernel::CHUNK` nodes, except the one holding the body's last, short
//! chunk; the vector paths work in windows of 64 nodes and blocks of 8. So what can go wrong at
//! a split is arithmetic on ranges that start or end inside a window, a chunk, or after the
//! last node. A rank that owned nothing after a short last chunk once swept that chunk and read
//! records below its own (a panic on 3 ranks, then a hang). The bodies here are boxes of exact
//! node counts, so that teams of 1 to 5 members (threads standing in for MPI ranks) give ranks
//! owning 0, 1, 63, 64, 65, 4095, 4096 and 4097 nodes, on every kernel: the cubic and
//! hexagonal stencils, the row kernel on AVX-512, on AVX2 and on its portable path, and CSR.
//!
//! Each run has the stable-step estimate (Lanczos, swept by the team), prescribed nodes at the
//! start of the body and loaded nodes at its end (so the middle ranks own neither), a body
//! force, damping, and breaking (a critical stretch that a random start exceeds here and there).
//! Every member must end with the lone run's state bit for bit, its broken springs, its
//! ledger and its checkpoint, holding the whole body, and, where the kernel sweeps rows, on
//! pieces cut from it. The set-up from parts and the whole runs with frames and checkpoints are
//! checked on shipped cases (`crates/case/tests/team.rs`, `every_split_of_a_small_case_runs`).

use std::sync::Arc;

use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::{Load, Loading, Motion, Prescribed, TimeFunction};
use hooke_core::team::{Share, Team, Threads};
use hooke_core::{Body, Lattice, Real, State, Vector};
use hooke_fracture::stretch::CriticalStretch;
use hooke_fracture::Fracture;
use hooke_tests::{random_displacement, Rng};

/// Which kernel a run takes, and how it is reached.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Path {
    /// The stencil of the box (cubic in 3D, hexagonal in 2D).
    Stencil,
    /// The row kernel on its best vector path (a box with one softened spring leaves the
    /// stencil).
    Rows,
    /// The row kernel on AVX2.
    RowsAvx2,
    /// The row kernel's portable path.
    RowsPortable,
    /// The CSR kernel.
    Csr,
}

const PATHS: [Path; 5] = [
    Path::Stencil,
    Path::Rows,
    Path::RowsAvx2,
    Path::RowsPortable,
    Path::Csr,
];

/// A box of `dims` nodes (three: a Ladd box; two: a hexagonal rectangle), with q = 0.3, a
/// random start, and for the row paths one spring softened.
fn body(dims: &[usize], path: Path) -> (Body, State) {
    let lattice = match *dims {
        [a, b, c] => Lattice::cubic_box([a, b, c], 1.0),
        [a, b] => Lattice::hex_box(a, b, 1.0, 1.0),
        _ => unreachable!(),
    }
    .unwrap();
    let n: usize = dims.iter().product();
    assert_eq!(lattice.len(), n, "{dims:?}");
    let body = Body::uniform(lattice, 1.0, 0.3, 1.0);
    let mut state = State::new(&body);
    let mut rng = Rng::new(n as u64);
    state.u = random_displacement(&body, &mut rng, 0.03);
    if !matches!(path, Path::Stencil | Path::Csr) {
        assert!(state.soften(&body, body.springs() / 2, 0.5));
    }
    (body, state)
}

fn options(path: Path) -> IntegratorOptions {
    IntegratorOptions {
        damping: 0.05,
        damage_proof: true,
        portable: path == Path::RowsPortable,
        avx2: path == Path::RowsAvx2,
        force_csr: path == Path::Csr,
        ..Default::default()
    }
}

/// The first nodes prescribed (moving along x), the last ones loaded, and a body force.
fn loading(n: usize) -> Loading {
    let m = (n / 8).clamp(1, 200);
    let dim3 = Vector::new(0.0, -1e-4, 0.0);
    Loading {
        prescribed: vec![Prescribed {
            nodes: (0..m as u32).collect(),
            axis: 0,
            motion: Motion::Velocity(TimeFunction::Constant(-1e-3)),
        }],
        loads: vec![Load {
            nodes: ((n - m) as u32..n as u32).collect(),
            force: Vector::new(2e-3, 1e-3, 0.0),
            scale: TimeFunction::Constant(1.0),
        }],
        body_acceleration: dim3,
    }
}

const STEPS: usize = 12;

/// What a run ends with, to compare bit for bit.
#[derive(Debug, PartialEq)]
struct End {
    u: Vec<u64>,
    v: Vec<u64>,
    alive: Vec<bool>,
    broken: usize,
    released: u64,
    checkpoint: String,
}

fn bits(x: &[Real]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// The run alone, or as member `team` holding the whole body, or its piece if `pieces`: the
/// state at the body's nodes `0..n` (a piece's own nodes, with their body indices).
fn run(
    dims: &[usize],
    path: Path,
    team: Option<Arc<dyn Team>>,
    pieces: bool,
) -> (End, Vec<usize>, String) {
    let (body, mut state) = body(dims, path);
    let n = body.nodes();
    let opts = options(path);
    let mut it = Integrator::new_shared(&body, &mut state, loading(n), &opts, team).unwrap();
    let name = it.kernel().name().to_string();
    let mut fr = Fracture::new(&body, Box::new(CriticalStretch::new(0.03).unwrap()));
    if pieces {
        let (pb, mut ps) = it.cut(&body, &state).unwrap();
        drop(state);
        fr.cut(it.piece().unwrap(), &pb);
        for _ in 0..STEPS {
            fr.step(&pb, &mut ps, &mut it, None);
        }
        it.check_shared(&pb, &mut ps).unwrap();
        let piece = it.piece().unwrap();
        let own = piece.own.clone();
        let global: Vec<usize> = own.clone().map(|i| piece.global[i] as usize).collect();
        let comps = |x: &hooke_core::Coords| -> Vec<u64> {
            (0..3).flat_map(|c| bits(&x.comp(c)[own.clone()])).collect()
        };
        // The piece's springs' fates at the body's springs (the others as the lone run has
        // them is not this piece's to say: they stay intact here).
        let mut alive = vec![true; body.springs()];
        for (b, &g) in piece.springs.iter().enumerate() {
            alive[g as usize] = ps.alive()[b];
        }
        let end = End {
            u: comps(&ps.u),
            v: comps(&ps.v),
            alive,
            broken: fr.broken_total,
            released: fr.released_total.to_bits(),
            checkpoint: format!("{:?}", it.checkpoint()),
        };
        return (end, global, name);
    }
    for _ in 0..STEPS {
        fr.step(&body, &mut state, &mut it, None);
    }
    it.gather_state(&mut state);
    it.check(&body, &state).unwrap();
    let end = End {
        u: bits(state.u.as_flat()),
        v: bits(state.v.as_flat()),
        alive: state.alive().to_vec(),
        broken: fr.broken_total,
        released: fr.released_total.to_bits(),
        checkpoint: format!("{:?}", it.checkpoint()),
    };
    (end, (0..n).collect(), name)
}

/// The body's values of the components `x` (three runs of `n`) at `nodes`, in a piece's
/// layout (each component's values at the nodes, one component after another).
fn at(x: &[u64], n: usize, nodes: &[usize]) -> Vec<u64> {
    (0..3)
        .flat_map(|c| nodes.iter().map(move |&i| x[c * n + i]))
        .collect()
}

/// Runs `dims` on `path` alone and on teams of 1 to 5, holding the whole body and (row
/// kernels) pieces; returns the node counts the ranks owned.
fn check(dims: &[usize], path: Path) -> Vec<usize> {
    let (alone, _, name) = run(dims, path, None, false);
    let n: usize = dims.iter().product();
    let want = match path {
        Path::Stencil => {
            if dims.len() == 3 {
                "cubic"
            } else {
                "hex"
            }
        }
        Path::Rows => "rows-avx",
        Path::RowsAvx2 => "rows-avx2",
        Path::RowsPortable => "rows",
        Path::Csr => "csr",
    };
    assert!(name.starts_with(want), "{dims:?} {path:?}: kernel {name}");
    assert!(alone.broken > 0, "{dims:?} {path:?}: nothing broke");
    let mut owned = Vec::new();
    for size in 1..=5 {
        let (body, _) = body(dims, path);
        owned.extend((0..size).map(|r| Share::new(&body, size, r, &[]).mine().len()));
        // A team of one is one process, which has no pieces to cut.
        let holds: &[bool] = if path == Path::Stencil || size == 1 {
            &[false]
        } else {
            &[false, true]
        };
        for &pieces in holds {
            let ends: Vec<(End, Vec<usize>, String)> = std::thread::scope(|s| {
                let handles: Vec<_> = Threads::team(size)
                    .into_iter()
                    .map(|t| s.spawn(move || run(dims, path, Some(Arc::new(t)), pieces)))
                    .collect();
                handles.into_iter().map(|h| h.join().unwrap()).collect()
            });
            let mut seen = 0;
            for (r, (end, nodes, _)) in ends.iter().enumerate() {
                let at_r =
                    format!("{dims:?} ({n} nodes) {path:?}, member {r} of {size}, pieces {pieces}");
                if pieces {
                    seen += nodes.len();
                    assert!(end.u == at(&alone.u, n, nodes), "{at_r}: u");
                    assert!(end.v == at(&alone.v, n, nodes), "{at_r}: v");
                    // A piece holds the springs of its rows: those must have the lone fates.
                    for (b, &fate) in end.alive.iter().enumerate() {
                        assert!(
                            fate || !alone.alive[b],
                            "{at_r}: spring {b} broke only here"
                        );
                    }
                    assert_eq!(end.broken, alone.broken, "{at_r}: broken");
                    assert_eq!(end.released, alone.released, "{at_r}: released");
                    assert_eq!(end.checkpoint, alone.checkpoint, "{at_r}: checkpoint");
                } else {
                    assert!(end == &alone, "{at_r}: ends elsewhere than the lone run");
                }
            }
            if pieces {
                assert_eq!(
                    seen, n,
                    "{dims:?} {path:?}: the pieces' own nodes cover the body"
                );
            }
        }
    }
    owned
}

/// Boxes whose node counts put 0, 1, 63, 64, 65, 4095, 4096 and 4097 nodes on some rank of a
/// team of 1 to 5, in 3D (Ladd boxes) and 2D (hexagonal rectangles); the comment is the count.
const BOXES_3D: [&[usize]; 8] = [
    &[3, 3, 7],    // 63
    &[4, 4, 4],    // 64
    &[5, 5, 5],    // 125
    &[13, 15, 21], // 4095
    &[16, 20, 13], // 4160 = 4096 + 64
    &[3, 19, 73],  // 4161 = 4096 + 65
    &[5, 13, 127], // 8255 = 2 x 4096 + 63
    &[16, 16, 32], // 8192 = 2 x 4096
];
const BOXES_2D: [&[usize]; 8] = [
    &[7, 9],     // 63
    &[8, 8],     // 64
    &[5, 13],    // 65
    &[63, 65],   // 4095
    &[17, 241],  // 4097 = 4096 + 1
    &[57, 73],   // 4161 = 4096 + 65
    &[64, 128],  // 8192 = 2 x 4096
    &[113, 145], // 16385 = 4 x 4096 + 1
];

fn check_all(boxes: &[&[usize]], wanted: &[usize]) {
    let mut owned = Vec::new();
    for dims in boxes {
        for path in PATHS {
            owned.extend(check(dims, path));
        }
    }
    owned.sort_unstable();
    owned.dedup();
    eprintln!("ranks owned these node counts: {owned:?}");
    for &want in wanted {
        assert!(
            owned.contains(&want),
            "no rank owned {want} nodes: {owned:?}"
        );
    }
}

#[test]
fn every_split_of_a_ladd_box_runs_with_the_bits_of_one_process() {
    // No Ladd box has 4097 nodes (17 x 241), and the balancer gives a lone node's chunk a
    // rank of its own only when it follows one other chunk: the plate covers 1 and 4097.
    check_all(&BOXES_3D, &[0, 63, 64, 65, 4095, 4096]);
}

#[test]
fn every_split_of_a_hexagonal_plate_runs_with_the_bits_of_one_process() {
    check_all(&BOXES_2D, &[0, 1, 63, 64, 65, 4095, 4096, 4097]);
}
