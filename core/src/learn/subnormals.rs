//! Subnormal numbers flushed to zero while a training runs (x86-64: MXCSR's FTZ and DAZ bits).
//!
//! Why: the targets are positions in world metres, so the LSTM's gates saturate and many of
//! the backward pass's products fall below `f32::MIN_POSITIVE`. On x86 every instruction that
//! reads or writes such a subnormal number takes a microcode assist, tens to a hundred cycles
//! instead of one: at 1000 robots this was 38 % of the training CPU (docs/PERFORMANCE.md,
//! "The parallel world and the speculation horizon"). TensorFlow, which trained the authors'
//! models, sets the same two bits on its CPU threads.
//!
//! What it changes: with FTZ a result that would be subnormal is 0 (of its sign), with DAZ a
//! subnormal operand is read as 0. Both are fixed IEEE-754 alternate behaviours, applied by
//! every SSE, AVX2 and AVX-512 instruction alike, so the bits stay the same on every x86-64
//! CPU, at every `target-cpu`, on 1 or N threads. They apply only between
//! [`FlushSubnormals::enter`] and the guard's drop, on the thread that entered: the SGD
//! epochs of a training (both threads of a two-thread one); the validation and held-out
//! losses run in the default mode.
//!
//! The compiler assumes the default mode (round to nearest, no flushing): it may fold a
//! constant expression that yields a subnormal, which the mode would have flushed. The kernels
//! under the guard compute on run-time data only, and each runs behind a function call the
//! guard's `asm!` cannot be moved across, so no folded value differs; the bit-identity tests
//! (debug against release, baseline against AVX2 and AVX-512, one thread against two) check it.
//!
//! On other architectures the guard does nothing; swarmfl's determinism is stated for x86-64.

/// MXCSR's flush-to-zero (bit 15) and denormals-are-zero (bit 6) bits.
#[cfg(target_arch = "x86_64")]
const FTZ_DAZ: u32 = (1 << 15) | (1 << 6);

/// While alive, this thread's SSE/AVX arithmetic flushes subnormal results and reads
/// subnormal operands as zero; dropping it restores the mode it found.
#[must_use = "the mode is restored when the guard drops"]
pub(super) struct FlushSubnormals {
    #[cfg(target_arch = "x86_64")]
    saved: u32,
}

impl FlushSubnormals {
    /// Sets FTZ and DAZ on this thread, remembering the mode to restore.
    pub(super) fn enter() -> FlushSubnormals {
        #[cfg(target_arch = "x86_64")]
        {
            let saved = read_mxcsr();
            write_mxcsr(saved | FTZ_DAZ);
            FlushSubnormals { saved }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            FlushSubnormals {}
        }
    }
}

impl Drop for FlushSubnormals {
    fn drop(&mut self) {
        #[cfg(target_arch = "x86_64")]
        write_mxcsr(self.saved);
    }
}

/// This thread's MXCSR.
#[cfg(target_arch = "x86_64")]
fn read_mxcsr() -> u32 {
    let mut value: u32 = 0;
    // SAFETY: `stmxcsr` stores the 32-bit control register to the given address, which is a
    // live, aligned `u32`; it has no other effect. x86-64 always has SSE.
    unsafe {
        std::arch::asm!(
            "stmxcsr [{}]",
            in(reg) &mut value,
            options(nostack, preserves_flags)
        );
    }
    value
}

/// Sets this thread's MXCSR. Not `nomem`/`pure`: the compiler must treat it as a side effect,
/// so it is neither removed nor moved across the calls around it.
#[cfg(target_arch = "x86_64")]
fn write_mxcsr(value: u32) {
    // SAFETY: `ldmxcsr` loads the control register from a live, aligned `u32`. The values
    // written are the register as read, with or without FTZ and DAZ: no reserved bit is set
    // (which would fault) and no exception is unmasked.
    unsafe {
        std::arch::asm!(
            "ldmxcsr [{}]",
            in(reg) &value,
            options(nostack, preserves_flags, readonly)
        );
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    /// MXCSR's control bits: the low six are sticky exception flags, which any arithmetic on
    /// subnormals sets.
    fn mode() -> u32 {
        read_mxcsr() & !0x3f
    }

    /// A subnormal product is flushed under the guard and kept outside it; the mode found is
    /// restored on drop.
    #[test]
    fn the_guard_flushes_subnormals_and_restores_the_mode() {
        let tiny = std::hint::black_box(f32::MIN_POSITIVE);
        let half = std::hint::black_box(0.5f32);
        let before = mode();
        assert!((tiny * half) > 0.0, "default mode keeps subnormals");
        {
            let _flush = FlushSubnormals::enter();
            assert_eq!(mode(), before | FTZ_DAZ);
            assert_eq!((std::hint::black_box(tiny) * half).to_bits(), 0);
            // DAZ: a subnormal operand reads as zero.
            let subnormal = std::hint::black_box(f32::from_bits(1));
            assert_eq!((subnormal * std::hint::black_box(2.0f32)).to_bits(), 0);
        }
        assert_eq!(mode(), before);
        assert!((std::hint::black_box(tiny) * half) > 0.0);
    }
}
