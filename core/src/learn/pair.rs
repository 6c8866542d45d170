//! One training on two cores, with the bits of one core.
//!
//! The groups of a mini-batch are independent until their gradients are added: each group's
//! forward pass, error and backpropagation through time ([`Workspace::forward`],
//! [`Workspace::error`], [`Workspace::backward_dz`]) read only the batch's weights and the
//! group's samples and masks. So the groups of a batch go to two threads, claimed by whichever
//! thread is free and computed in that thread's own workspace. The thread that computed a group
//! also adds its gradient into the batch gradient, in data order: it waits until the groups
//! before it are in, and while it waits it sums each of its samples' gradients apart
//! ([`Workspace::partials`]), so that only the final additions wait ([`add_partials`]; the
//! same terms in the same order as [`Workspace::accumulate`]). Then the thread that owns the
//! training adds the squared errors into the epoch's sum, group after group, and takes the SGD
//! step. Every sum has the order of the one-thread loop, and the dropout masks are drawn from
//! the robot's stream in the same order before the batch is handed out, so the result is
//! bit-identical to it whoever computed which group (the tests compare them, and
//! `scripts/determinism.sh` compares whole runs on one and two threads).
//!
//! Why the adding follows the group: a group's per-step buffers are about 100 KiB, the
//! gradient 11 KiB. An owner that adds every group reads the helper's buffers from the other
//! core's cache (adding the helper's group then takes about twice as long as adding its own),
//! and the helper's next writes to those buffers miss too. The partial sums keep a waiting
//! thread busy instead of idle. docs/PERFORMANCE.md, "Training kernels", has the
//! measurements.
//!
//! Why not rayon: a batch of 20 samples takes about 150 µs, and waking a sleeping pool worker
//! for each batch costs tens of microseconds on the reference VM. Here the helper thread lives
//! for one training and spins between batches (parking after a short while), and the groups
//! are *claimed*, never assigned: if the helper is slow to wake (another process holds the
//! core), the owner computes every group itself and never waits for a group nobody started.
//!
//! A process-wide count of trainings in progress keeps the helper out of the way when the cores
//! are already busy with other trainings (several robots training at once, sweep jobs): a
//! training spawns a helper only when it is the only one running, and stops waking it while
//! another one runs. Programs that run several simulations at once turn helpers off
//! ([`set_allowed`]). A helper for every training, joining once the other trainings end, was
//! tried and not kept: a `paper` run took longer and more CPU (docs/PERFORMANCE.md, "The paper
//! run").

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, RwLock};

use ndarray::{Array1, Array2};

use super::kernels::{add_partials, Mat, Workspace, GROUP};
use super::{grad_scale, Portable, Resolved, Sgd, TrainData};
use crate::rng::Rng;

/// Trainings in progress in this process that may use a helper thread.
static ACTIVE: AtomicUsize = AtomicUsize::new(0);

/// Spin iterations a waiting thread makes before it yields (owner) or parks (helper).
const SPIN: u32 = 50_000;

/// Counts this training in [`ACTIVE`] while alive (background trainings, which run on one
/// thread, enter it too: see `background.rs`).
pub(super) struct Active;

impl Active {
    /// Registers a training; true if it is the only one in progress.
    pub(super) fn enter() -> (Active, bool) {
        let before = ACTIVE.fetch_add(1, Ordering::SeqCst);
        (Active, before == 0)
    }
}

impl Drop for Active {
    fn drop(&mut self) {
        ACTIVE.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Whether [`Threads::Auto`](super::Threads::Auto) may give a training a helper thread.
static ALLOWED: AtomicBool = AtomicBool::new(true);

/// Allows or forbids helper threads for [`Threads::Auto`](super::Threads::Auto) trainings in
/// this process (allowed by default). A program that runs several simulations side by side
/// (`swarmfl sweep --jobs 2`) forbids them: the count of trainings in progress cannot see the
/// other simulations' world and ledger work, which already fills the cores. Speed only: the
/// bits are the same either way.
pub fn set_allowed(allowed: bool) {
    ALLOWED.store(allowed, Ordering::SeqCst);
}

/// Whether a training should use two threads: allowed ([`set_allowed`]), at least two
/// threads in rayon's pool (so `RAYON_NUM_THREADS=1` means one thread everywhere) and enough
/// samples for two groups.
pub(super) fn worth_it(samples: usize, batch: usize) -> bool {
    ALLOWED.load(Ordering::Relaxed)
        && rayon::current_num_threads() >= 2
        && batch.min(samples) > GROUP / 2
}

/// One group of the current batch: its samples, its dropout masks and its squared errors.
struct Slot {
    /// First and one-past-last sample of the group.
    first: usize,
    last: usize,
    /// d(loss)/dy scale of the group's batch.
    scale: f32,
    /// The group's dropout masks (`GROUP x units`), drawn by the owner before the batch is
    /// handed out.
    mask: Array2<f32>,
    /// Squared error of each sample of the group, in order.
    sse: [f64; GROUP],
}

/// One thread's buffers: whichever group the thread claims is computed here, so a thread's
/// per-step buffers stay in its own core's cache from batch to batch. (With a workspace per
/// group instead, the helper took group 0 in about half the batches and each thread then
/// read the other's buffers, so every group's passes ran slower than on one thread.)
struct Work {
    ws: Workspace,
    /// Each sample's own gradient (`GROUP x weights`), computed while the group waits for its
    /// turn to be added ([`Workspace::partials`]).
    partials: Array2<f32>,
}

impl Work {
    fn new(shape: &super::ModelShape) -> Work {
        Work {
            ws: Workspace::new(shape),
            partials: Array2::zeros((GROUP, shape.weights())),
        }
    }
}

/// What the owner and the helper share for one training.
struct Shared<'a> {
    data: &'a TrainData,
    /// The weights of the current batch (written by the owner between batches only).
    weights: RwLock<Array1<f32>>,
    slots: Vec<Mutex<Slot>>,
    /// `epoch << 32 | groups << 16 | next`: the batch being handed out, its group count and the
    /// next unclaimed group. A claim is a compare-and-swap on the whole word, so a stale
    /// claimer (one still finishing the previous batch) can never take a group of a new one.
    claim: AtomicU64,
    /// The batch's gradient, which the groups are added into in data order.
    grad: Mutex<Array1<f32>>,
    /// `epoch << 32 | added`: how many groups of batch `epoch` have been added into `grad`.
    added: AtomicU64,
    stop: AtomicBool,
    /// Use the helper even while other trainings run (tests and benchmarks).
    force: bool,
    /// The helper is parked (or about to park) and needs an unpark to see a new batch.
    parked: AtomicBool,
}

fn pack(epoch: u32, groups: usize, next: usize) -> u64 {
    (u64::from(epoch) << 32) | ((groups as u64) << 16) | next as u64
}

fn pack_added(epoch: u32, added: usize) -> u64 {
    (u64::from(epoch) << 32) | added as u64
}

/// Spins until `ready()`, yielding the core after [`SPIN`] tries (the other thread may be
/// waiting for it, if another process holds the second core).
#[inline(always)]
fn spin_until(ready: impl Fn() -> bool) {
    let mut spins = 0u32;
    while !ready() {
        spins += 1;
        if spins < SPIN {
            std::hint::spin_loop();
        } else {
            std::thread::yield_now();
        }
    }
}

impl Shared<'_> {
    /// Claims the next group of batch `epoch`, if any is left.
    fn claim(&self, epoch: u32) -> Option<usize> {
        let mut word = self.claim.load(Ordering::Acquire);
        loop {
            let (e, groups, next) = (
                (word >> 32) as u32,
                ((word >> 16) & 0xffff) as usize,
                (word & 0xffff) as usize,
            );
            if e != epoch || next >= groups {
                return None;
            }
            match self.claim.compare_exchange_weak(
                word,
                word + 1,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => return Some(next),
                Err(now) => word = now,
            }
        }
    }

    /// Forward pass, errors and backpropagation of group `k`; then, once groups `0..k` are in
    /// the batch gradient, adds this one's. The thread that computed a group adds it, so the
    /// group's per-step buffers (about 100 KiB) never cross to the other core's cache; only
    /// the gradient (11 KiB) does. If the group's turn has not come yet when its
    /// backpropagation ends (the other thread is still adding the group before), the waiting
    /// thread sums each sample's gradient apart ([`Workspace::partials`]) and then adds only
    /// those sums, so most of the adding runs on both cores at once; the bits are the same.
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    unsafe fn compute<M: Mat>(&self, work: &mut Work, k: usize, epoch: u32) {
        let Work { ws, partials } = work;
        let n = {
            let mut slot = self.slots[k].lock().unwrap_or_else(|e| e.into_inner());
            let weights = self.weights.read().unwrap_or_else(|e| e.into_inner());
            let w = weights
                .as_slice()
                .expect("owned arrays have the standard layout");
            let Slot {
                first,
                last,
                scale,
                mask,
                sse,
            } = &mut *slot;
            ws.mask.assign(mask);
            ws.transpose_weights(w);
            // SAFETY: the caller guarantees the CPU runs `M`.
            unsafe { ws.forward::<M>(w, self.data.inputs(*first, *last)) };
            for (s, i) in (*first..*last).enumerate() {
                sse[s] = ws.error(s, self.data.target(i), *scale);
            }
            // SAFETY: as above.
            unsafe { ws.backward_dz::<M>(*last - *first) };
            *last - *first
        };
        // The group before this one is being computed or added by a thread that is not waiting
        // for this one (a thread adds only what it computed, and groups are claimed in order),
        // so this wait always ends.
        let turn = pack_added(epoch, k);
        let early = self.added.load(Ordering::Acquire) != turn;
        if early {
            // SAFETY: as above.
            unsafe { ws.partials::<M>(partials, n) };
        }
        spin_until(|| self.added.load(Ordering::Acquire) == turn);
        {
            let mut grad = self.grad.lock().unwrap_or_else(|e| e.into_inner());
            let g = grad
                .as_slice_mut()
                .expect("owned arrays have the standard layout");
            if early {
                add_partials(g, partials, n);
            } else {
                // SAFETY: as above.
                unsafe { ws.accumulate::<M>(g, n) };
            }
        }
        self.added
            .store(pack_added(epoch, k + 1), Ordering::Release);
    }

    /// The helper's life: wait for a batch, claim and compute groups, until told to stop.
    ///
    /// # Safety
    /// The CPU has the instruction set `M` is compiled for.
    #[inline(always)]
    unsafe fn helper<M: Mat>(&self) {
        let mut work = Work::new(&self.data.shape);
        let mut seen = 0u32;
        loop {
            let mut spins = 0u32;
            let epoch = loop {
                if self.stop.load(Ordering::Acquire) {
                    return;
                }
                let e = (self.claim.load(Ordering::Acquire) >> 32) as u32;
                if e != seen {
                    break e;
                }
                spins += 1;
                if spins < SPIN {
                    std::hint::spin_loop();
                } else {
                    // Park; the owner unparks after publishing a batch if it sees the flag.
                    // Re-checking after setting it closes the race with that publication.
                    self.parked.store(true, Ordering::SeqCst);
                    let e = (self.claim.load(Ordering::SeqCst) >> 32) as u32;
                    if e == seen && !self.stop.load(Ordering::SeqCst) {
                        std::thread::park();
                    }
                    self.parked.store(false, Ordering::SeqCst);
                    spins = 0;
                }
            };
            seen = epoch;
            // Another training started since this one: its thread needs the core more than a
            // helper does (the owner then computes every group itself).
            if !self.force && ACTIVE.load(Ordering::Relaxed) > 1 {
                continue;
            }
            while let Some(k) = self.claim(epoch) {
                // SAFETY: the caller guarantees the CPU runs `M`.
                unsafe { self.compute::<M>(&mut work, k, epoch) };
            }
        }
    }

    fn wake(&self, helper: &std::thread::Thread) {
        if self.parked.swap(false, Ordering::SeqCst) {
            helper.unpark();
        }
    }
}

/// The epochs of SGD on two threads; the same result as `train_loop`.
///
/// # Safety
/// The CPU has the instruction set `M` is compiled for.
#[inline(always)]
unsafe fn owner<M: Mat>(
    shared: &Shared<'_>,
    helper: &std::thread::Thread,
    sgd: &Sgd,
    dropout: &mut Rng,
) -> f64 {
    let outputs = shared.data.shape.outputs();
    let mut work = Work::new(&shared.data.shape);
    let mut epoch_sse = 0.0f64;
    let mut epoch = 0u32;
    for _ in 0..sgd.epochs {
        epoch_sse = 0.0;
        for (start, end) in sgd.batches() {
            let scale = grad_scale(end - start, outputs);
            // The batch's groups, and their masks drawn in sample order (as `train_loop`).
            let mut groups = 0;
            for (first, last) in super::groups(start, end) {
                let mut slot = shared.slots[groups]
                    .lock()
                    .unwrap_or_else(|e| e.into_inner());
                slot.first = first;
                slot.last = last;
                slot.scale = scale;
                sgd.draw_masks(&mut slot.mask, last - first, dropout);
                groups += 1;
            }
            epoch = epoch.wrapping_add(1).max(1);
            shared
                .grad
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .fill(0.0);
            shared.added.store(pack_added(epoch, 0), Ordering::SeqCst);
            shared.claim.store(pack(epoch, groups, 0), Ordering::SeqCst);
            if shared.force || ACTIVE.load(Ordering::Relaxed) == 1 {
                shared.wake(helper);
            }
            while let Some(k) = shared.claim(epoch) {
                // SAFETY: this function's caller guarantees the CPU runs `M`.
                unsafe { shared.compute::<M>(&mut work, k, epoch) };
            }
            let all = pack_added(epoch, groups);
            spin_until(|| shared.added.load(Ordering::Acquire) == all);
            for slot in &shared.slots[..groups] {
                let slot = slot.lock().unwrap_or_else(|e| e.into_inner());
                for s in 0..slot.last - slot.first {
                    epoch_sse += slot.sse[s];
                }
            }
            let grad = shared.grad.lock().unwrap_or_else(|e| e.into_inner());
            shared
                .weights
                .write()
                .unwrap_or_else(|e| e.into_inner())
                .zip_mut_with(&grad, |w, g| *w -= *g * sgd.lr);
        }
    }
    epoch_sse / (sgd.samples * outputs) as f64
}

/// Stops the helper when the owner leaves, normally or by a panic (so the scope can join it).
struct StopOnDrop<'s, 'a> {
    shared: &'s Shared<'a>,
    helper: std::thread::Thread,
}

impl Drop for StopOnDrop<'_, '_> {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.helper.unpark();
    }
}

macro_rules! variants {
    ($owner:ident, $helper:ident, $feature:literal, $m:ty) => {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feature)]
        unsafe fn $owner(
            shared: &Shared<'_>,
            helper: &std::thread::Thread,
            sgd: &Sgd,
            dropout: &mut Rng,
        ) -> f64 {
            // SAFETY: this function's caller checked the CPU.
            unsafe { owner::<$m>(shared, helper, sgd, dropout) }
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feature)]
        unsafe fn $helper(shared: &Shared<'_>) {
            // SAFETY: this function's caller checked the CPU.
            unsafe { shared.helper::<$m>() }
        }
    };
}

variants!(owner_avx512, helper_avx512, "avx512f", super::simd::Avx512);
variants!(owner_avx2, helper_avx2, "avx2", super::simd::Avx2);

fn run_owner(
    kernel: Resolved,
    shared: &Shared<'_>,
    helper: &std::thread::Thread,
    sgd: &Sgd,
    dropout: &mut Rng,
) -> f64 {
    match kernel {
        // SAFETY: the portable kernels run on any CPU.
        Resolved::Baseline => unsafe { owner::<Portable>(shared, helper, sgd, dropout) },
        // SAFETY: `Kernel::resolve` checked at run time that the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx2 => unsafe { owner_avx2(shared, helper, sgd, dropout) },
        // SAFETY: `Kernel::resolve` checked at run time that the CPU has AVX-512F.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx512 => unsafe { owner_avx512(shared, helper, sgd, dropout) },
    }
}

#[inline(never)]
fn run_helper(kernel: Resolved, shared: &Shared<'_>) {
    match kernel {
        // SAFETY: the portable kernels run on any CPU.
        Resolved::Baseline => unsafe { shared.helper::<Portable>() },
        // SAFETY: `Kernel::resolve` checked at run time that the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx2 => unsafe { helper_avx2(shared) },
        // SAFETY: `Kernel::resolve` checked at run time that the CPU has AVX-512F.
        #[cfg(target_arch = "x86_64")]
        Resolved::Avx512 => unsafe { helper_avx512(shared) },
    }
}

/// The SGD epochs of one training on two threads if no other training is in progress, or if
/// `force` (else on this thread alone, through `single`); returns the last epoch's training
/// loss. Same bits either way.
pub(super) fn train(
    kernel: Resolved,
    force: bool,
    weights: &mut Array1<f32>,
    data: &TrainData,
    sgd: &Sgd,
    dropout: &mut Rng,
    single: impl FnOnce(&mut Array1<f32>, &mut Rng) -> f64,
) -> f64 {
    let (_active, alone) = Active::enter();
    if !alone && !force {
        return single(weights, dropout);
    }
    let groups = sgd.batch.min(sgd.samples).div_ceil(GROUP);
    assert!(groups < 1 << 16, "batch of {} samples", sgd.batch);
    let shared = Shared {
        data,
        weights: RwLock::new(std::mem::replace(weights, Array1::zeros(0))),
        slots: (0..groups)
            .map(|_| {
                Mutex::new(Slot {
                    first: 0,
                    last: 0,
                    scale: 0.0,
                    mask: Array2::zeros((GROUP, data.shape.units())),
                    sse: [0.0; GROUP],
                })
            })
            .collect(),
        claim: AtomicU64::new(0),
        grad: Mutex::new(Array1::zeros(data.shape.weights())),
        added: AtomicU64::new(0),
        stop: AtomicBool::new(false),
        force,
        parked: AtomicBool::new(false),
    };
    let loss = std::thread::scope(|scope| {
        let handle = scope.spawn(|| {
            // The owner's epochs run in this mode too (`learn::train_threads`).
            let _flush = super::subnormals::FlushSubnormals::enter();
            run_helper(kernel, &shared);
        });
        let _stop = StopOnDrop {
            shared: &shared,
            helper: handle.thread().clone(),
        };
        run_owner(kernel, &shared, handle.thread(), sgd, dropout)
    });
    *weights = shared
        .weights
        .into_inner()
        .unwrap_or_else(|e| e.into_inner());
    loss
}
