//! Firmware example: embeds the shipped built-in-scene models (int8 and
//! int16 weights, kept in flash by `include_bytes!`; or the model given to
//! `run --model`), renders one tile of a
//! fixed view with `nerf-infer`'s integer-only path, prints the cost and a
//! few pixels over semihosting, and exits with status 0 only if every pixel
//! equals the host's render of the same tile bit for bit (`expected.rs`).
//!
//! Cost is counted in instructions: QEMU runs with `-icount shift=0` (one
//! instruction per virtual nanosecond) and SysTick measures virtual time,
//! calibrated against a loop of known length. RAM is the static sections
//! (`size`; the scratch is one, made by the `const fn` `ScratchFixed::new`)
//! plus the stack high-water mark, found by painting the stack; the stack
//! each library call needs beyond its caller's frame (decoding, making the
//! renderer, rendering the tile) is found the same way, and
//! `scripts/check/stack_table.sh` in the workspace collects it per target.

#![no_std]
#![no_main]

use core::ptr::{addr_of, addr_of_mut};
use core::sync::atomic::{AtomicU32, AtomicUsize, Ordering};

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use nerf_infer::{render_tile, Camera, Model, PixelFixed, RayRenderer, RenderOptions, RendererFixed, ScratchFixed};
use panic_semihosting as _;

#[cfg(not(user_model))]
mod expected;
/// The host's render of the tile for the model `run --model` gave.
#[cfg(user_model)]
mod expected {
    include!(concat!(env!("OUT_DIR"), "/user_expected.rs"));
}
mod view;

/// A model in flash (`Model::from_bytes` borrows, it never copies), its
/// name, and the host's render of the tile: pixels and checksum.
type Case = (&'static str, &'static [u8], &'static [(u16, u16, u16, u16, i32); view::PIXELS], u32);

/// The shipped models of the built-in scene.
#[cfg(not(user_model))]
static MODELS: [Case; 2] = [
    ("int8", include_bytes!("../../../models/scene_int8.nerf"), &expected::INT8, expected::INT8_CHECKSUM),
    ("int16", include_bytes!("../../../models/scene_int16.nerf"), &expected::INT16, expected::INT16_CHECKSUM),
];
/// The model `run --model` gave.
#[cfg(user_model)]
static MODELS: [Case; 1] = [(
    "model",
    include_bytes!(concat!(env!("OUT_DIR"), "/user_model.nerf")),
    &expected::MODEL,
    expected::MODEL_CHECKSUM,
)];

/// Samples evaluated together: 4 keeps the scratch at 26 KiB.
const BLOCK: usize = 4;

/// The renderer's working memory, in `.bss` (zeroed at reset, no flash).
static mut SCRATCH: ScratchFixed<BLOCK> = ScratchFixed::new();

/// SysTick reload value (24-bit counter, counts down).
const RELOAD: u32 = 0x00FF_FFFF;
/// SysTick wraps since start, counted by the exception handler.
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Ticks since SysTick started (wrap-safe).
fn ticks() -> u64 {
    loop {
        let w = WRAPS.load(Ordering::Acquire);
        let v = SYST::get_current();
        if WRAPS.load(Ordering::Acquire) == w {
            return w as u64 * (RELOAD as u64 + 1) + (RELOAD - v) as u64;
        }
    }
}

/// Executes `2·n` instructions (`subs` + `bne` per turn) plus a few.
#[inline(never)]
fn spin(n: u32) {
    // SAFETY: a register-only countdown loop; touches no memory.
    unsafe {
        core::arch::asm!("2:", "subs {0}, {0}, #1", "bne 2b", inout(reg) n => _, options(nomem, nostack));
    }
}

/// Instruction clock: SysTick ticks → instructions, from a calibration loop.
struct Clock {
    /// Instructions in the calibration loop.
    instructions: u64,
    /// Ticks it took.
    ticks: u64,
}

impl Clock {
    fn calibrate() -> Self {
        const TURNS: u32 = 5_000_000;
        let t0 = ticks();
        spin(TURNS);
        let t1 = ticks();
        Self { instructions: 2 * TURNS as u64, ticks: (t1 - t0).max(1) }
    }

    /// Instructions in `ticks` (rounded).
    fn instructions(&self, ticks: u64) -> u64 {
        (ticks * self.instructions + self.ticks / 2) / self.ticks
    }

    /// Instructions spent in `f`, and its result.
    fn count<T>(&self, f: impl FnOnce() -> T) -> (u64, T) {
        let t0 = ticks();
        let r = f();
        let t1 = ticks();
        (self.instructions(t1 - t0), r)
    }
}

const PAINT: u32 = 0x5AFE_C0DE;

extern "C" {
    /// Start of the free RAM above `.bss` (cortex-m-rt's linker script).
    static mut __sheap: u32;
    /// Initial stack pointer: the top of RAM.
    static _stack_start: u32;
}

/// Fills the free stack below the current stack pointer with [`PAINT`].
#[inline(always)]
fn paint_stack() {
    // SAFETY: writes only words between the end of the static sections and
    // the current stack pointer, which nothing uses yet.
    unsafe {
        let mut p = addr_of_mut!(__sheap);
        let sp = cortex_m::register::msp::read() as *mut u32;
        while p < sp {
            p.write_volatile(PAINT);
            p = p.add(1);
        }
    }
}

/// Calls `f` in a frame of its own.
#[inline(never)]
fn call<T>(f: impl FnOnce() -> T) -> T {
    f()
}

/// The stack `f` needs below its caller's stack pointer (its deepest
/// point, bytes), and its result.
#[inline(always)]
fn stack_used<T>(f: impl FnOnce() -> T) -> (usize, T) {
    let sp = cortex_m::register::msp::read() as usize;
    paint_stack();
    let r = call(f);
    // SAFETY: reads words of RAM between the static sections and the stack pointer.
    let lowest = unsafe {
        let mut p = addr_of!(__sheap);
        while (p as usize) < sp && p.read_volatile() == PAINT {
            p = p.add(1);
        }
        p as usize
    };
    // (a later paint covers this call's depth: keep it for the high-water mark)
    DEEPEST.fetch_max(addr_of!(_stack_start) as usize - lowest, Ordering::Relaxed);
    (sp.saturating_sub(lowest), r)
}

/// The deepest stack [`stack_used`] saw, bytes from the top of RAM.
static DEEPEST: AtomicUsize = AtomicUsize::new(0);

/// The most stack each library call needed, bytes beyond its caller's frame.
#[derive(Default)]
struct Stack {
    decode: usize,
    renderer: usize,
    render_tile: usize,
}

/// Deepest stack use so far, in bytes from the top of RAM (since the last
/// paint, or in a call [`stack_used`] measured).
fn stack_high_water() -> usize {
    // SAFETY: reads words of RAM between the static sections and the top.
    unsafe {
        let top = addr_of!(_stack_start) as usize;
        let mut p = addr_of!(__sheap);
        while (p as usize) < top && p.read_volatile() == PAINT {
            p = p.add(1);
        }
        (top - p as usize).max(DEEPEST.load(Ordering::Relaxed))
    }
}

fn as_tuple(p: &PixelFixed) -> (u16, u16, u16, u16, i32) {
    (p.rgb[0], p.rgb[1], p.rgb[2], p.opacity, p.depth)
}

/// Renders the view's tile of `blob` ray by ray and as a tile, prints the
/// cost and a few pixels, and returns whether both match `want` exactly.
fn run(
    name: &str,
    blob: &'static [u8],
    want: &[(u16, u16, u16, u16, i32); view::PIXELS],
    want_sum: u32,
    clock: &Clock,
    scratch: &mut ScratchFixed<BLOCK>,
    stack: &mut Stack,
) -> bool {
    let (used, (decode, model)) = stack_used(|| clock.count(|| Model::from_bytes(blob)));
    stack.decode = stack.decode.max(used);
    let model = match model {
        Ok(m) => m,
        Err(e) => {
            hprintln!("{}: model rejected: {}", name, e);
            return false;
        }
    };
    let (used, renderer) = stack_used(|| RendererFixed::new(&model, RenderOptions::from_model(&model)));
    stack.renderer = stack.renderer.max(used);
    let renderer = match renderer {
        Ok(r) => r,
        Err(e) => {
            hprintln!("{}: renderer rejected the model: {}", name, e);
            return false;
        }
    };
    let camera = Camera::from_fov(view::WIDTH, view::HEIGHT, view::FOV_X, view::POSE).expect("rigid pose");
    let tile = view::TILE;

    // Ray by ray: per-ray cost (min / max).
    let mut rays = [PixelFixed::default(); view::PIXELS];
    let (mut lo, mut hi) = (u64::MAX, 0);
    for (k, px) in rays.iter_mut().enumerate() {
        let (x, y) = (tile.x0 + k as u32 % tile.width, tile.y0 + k as u32 / tile.width);
        let (cost, p) = clock.count(|| {
            let (o, d) = camera.ray(x, y);
            renderer.render_ray(o, d, (x, y), scratch)
        });
        *px = p;
        lo = lo.min(cost);
        hi = hi.max(cost);
    }

    // The whole tile at once.
    let mut pixels = [PixelFixed::default(); view::PIXELS];
    let evals0 = scratch.evaluations;
    let (used, (tile_cost, res)) =
        stack_used(|| clock.count(|| render_tile(&renderer, &camera, tile, scratch, &mut pixels)));
    stack.render_tile = stack.render_tile.max(used);
    if let Err(e) = res {
        hprintln!("{}: render_tile failed: {}", name, e);
        return false;
    }
    let evals = scratch.evaluations - evals0;

    let sum = view::checksum(&pixels);
    let mismatches = pixels.iter().zip(want.iter()).filter(|(p, w)| as_tuple(p) != **w).count();
    let ray_tile_differ = rays.iter().zip(pixels.iter()).filter(|(a, b)| a != b).count();
    hprintln!(
        "{}: {} bytes in flash, decode+validate {} instructions, {} network evaluations",
        name,
        blob.len(),
        decode,
        evals
    );
    hprintln!(
        "{}: tile {}x{} = {} instructions; per ray {} mean, {} min, {} max",
        name,
        tile.width,
        tile.height,
        tile_cost,
        tile_cost / view::PIXELS as u64,
        lo,
        hi
    );
    for k in [0, view::PIXELS / 2 + tile.width as usize / 2, view::PIXELS - 1] {
        let (r, g, b, a, d) = as_tuple(&pixels[k]);
        hprintln!("{}: pixel {:2}: rgb ({}, {}, {}) Q15, opacity {} Q15, depth {} Q16", name, k, r, g, b, a, d);
    }
    let ok = mismatches == 0 && ray_tile_differ == 0 && sum == want_sum;
    hprintln!(
        "{}: checksum {:08x} (host {:08x}), {} of {} pixels differ from the host{}: {}",
        name,
        sum,
        want_sum,
        mismatches,
        view::PIXELS,
        if ray_tile_differ > 0 { ", ray-by-ray and tile renders disagree" } else { "" },
        if ok { "BIT-EXACT" } else { "MISMATCH" }
    );
    ok
}

#[entry]
fn main() -> ! {
    paint_stack();
    let mut cp = cortex_m::Peripherals::take().expect("first take");
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(RELOAD);
    cp.SYST.clear_current();
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();
    // The counter reads 0 until its first reload: let it start.
    while SYST::get_current() == 0 {}

    let clock = Clock::calibrate();
    hprintln!(
        "nerf-cortex-m on {}: calibration {} instructions in {} SysTick ticks",
        env!("NERF_BOARD"),
        clock.instructions,
        clock.ticks
    );
    // SAFETY: the one reference to SCRATCH, taken once; no interrupt uses it.
    let scratch = unsafe { &mut *addr_of_mut!(SCRATCH) };
    let (mut ok, mut stack) = (true, Stack::default());
    for (name, blob, want, sum) in &MODELS {
        ok &= run(name, blob, want, *sum, &clock, scratch, &mut stack);
    }
    hprintln!(
        "ram: stack high-water {} bytes; scratch {} bytes (static); flash: models {} bytes",
        stack_high_water(),
        core::mem::size_of::<ScratchFixed<BLOCK>>(),
        MODELS.iter().map(|m| m.1.len()).sum::<usize>()
    );
    // for scripts/check/stack_table.sh: bytes, key=value
    hprintln!(
        "stack: decode={} renderer={} render_tile={} high_water={} (beyond the caller's frame; high_water from the top)",
        stack.decode,
        stack.renderer,
        stack.render_tile,
        stack_high_water()
    );
    hprintln!(
        "sizes: Model={} RendererFixed={} ScratchFixed1={} ScratchFixed4={} ScratchFixed8={} ScratchF32_1={} \
         ScratchF32_8={}",
        core::mem::size_of::<Model<'static>>(),
        core::mem::size_of::<RendererFixed<'static, 'static>>(),
        core::mem::size_of::<ScratchFixed<1>>(),
        core::mem::size_of::<ScratchFixed<4>>(),
        core::mem::size_of::<ScratchFixed<8>>(),
        core::mem::size_of::<nerf_infer::ScratchF32<1>>(),
        core::mem::size_of::<nerf_infer::ScratchF32<8>>()
    );
    hprintln!("{}", if ok { "PASS: bit-exact with the host" } else { "FAIL" });
    debug::exit(if ok { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    #[allow(clippy::empty_loop)]
    loop {}
}
