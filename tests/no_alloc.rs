//! A step allocates nothing: counted with a global allocator around 200 steps on each kernel,
//! with loads, supports, damping and 2 threads, and with the break check folded into the step.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use hooke_core::dynamics::{Integrator, IntegratorOptions};
use hooke_core::loading::{Load, Loading, Motion, Prescribed, TimeFunction};
use hooke_core::{Body, Lattice, State, Vector};
use hooke_fracture::{CriticalStretch, Fracture};

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded unchanged to the system allocator, which meets the contract.
unsafe impl GlobalAlloc for Counting {
    /// # Safety
    /// The [`GlobalAlloc`] contract for this method; it is passed on to the allocator below.
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(l) }
    }
    /// # Safety
    /// The [`GlobalAlloc`] contract for this method; it is passed on to the allocator below.
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steps_allocate_nothing() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| {
        for force_csr in [false, true] {
            let body = Body::uniform(
                Lattice::cubic_box([30, 20, 20], 1.0).unwrap(),
                1.0,
                0.3,
                1.0,
            );
            let mut state = State::new(&body);
            let ends: Vec<u32> = (0..body.nodes() as u32)
                .filter(|&i| body.lattice.pos.x()[i as usize] == 0.0)
                .collect();
            let far: Vec<u32> = (0..body.nodes() as u32)
                .filter(|&i| body.lattice.pos.x()[i as usize] == 29.0)
                .collect();
            let loading = Loading {
                prescribed: vec![Prescribed {
                    nodes: ends,
                    axis: 0,
                    motion: Motion::Fixed,
                }],
                loads: vec![Load {
                    nodes: far,
                    force: Vector::new(1e-3, 0.0, 0.0),
                    scale: TimeFunction::Constant(1.0),
                }],
                body_acceleration: Vector::new(0.0, -1e-6, 0.0),
            };
            let opts = IntegratorOptions {
                damping: 0.01,
                force_csr,
                ..Default::default()
            };
            let fracture_state = state.clone();
            let mut it = Integrator::new(&body, &mut state, loading.clone(), &opts).unwrap();
            it.run(&body, &mut state, 10).unwrap(); // warm up the thread pool
            let before = ALLOCATIONS.load(Ordering::Relaxed);
            it.run(&body, &mut state, 200).unwrap();
            let during = ALLOCATIONS.load(Ordering::Relaxed) - before;
            assert_eq!(
                during,
                0,
                "kernel {}: {during} allocations in 200 steps",
                it.kernel().name()
            );
            // The folded break check: a screen every stretched spring passes (all nodes no-fail,
            // so every flagged spring is examined and none breaks), and one nothing passes.
            for (s_c, no_fail) in [(1e-12, true), (1.0, false)] {
                let mut st = fracture_state.clone();
                let mut it = Integrator::new(&body, &mut st, loading.clone(), &opts).unwrap();
                let mut fr = Fracture::new(&body, Box::new(CriticalStretch::new(s_c).unwrap()));
                if no_fail {
                    fr.set_no_fail(&(0..body.nodes() as u32).collect::<Vec<_>>());
                }
                for _ in 0..10 {
                    fr.step(&body, &mut st, &mut it, None);
                }
                let before = ALLOCATIONS.load(Ordering::Relaxed);
                for _ in 0..200 {
                    fr.step(&body, &mut st, &mut it, None);
                }
                let during = ALLOCATIONS.load(Ordering::Relaxed) - before;
                assert_eq!(
                    during,
                    0,
                    "kernel {} with fracture (s_c {s_c}): {during} allocations in 200 steps",
                    it.kernel().name()
                );
                assert_eq!(fr.broken_total, 0);
            }
        }
    });
}
