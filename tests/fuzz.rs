//! Fuzzing of every parser that reads a file a person hands us (issue 16 item 1): the EHdr
//! header and data file (and a mosaic of two), the netCDF-3 header and the CF raster adaptor,
//! the pyramid file's header, level table and tiles, and the detail parameter file (JSON, what
//! the editor saves and `--detail FILE` loads).
//!
//! The harness is a deterministic mutation loop over valid seeds, written here so that it runs
//! as an ordinary `cargo test` on stable Rust and adds no dependency: a seeded generator picks
//! an input from the pool, stacks a few mutations on it (bit flips, interesting bytes, byte
//! insert/delete, splices from another input, integer-boundary values written over header
//! fields in the format's byte order, numbers in text replaced by boundary values, repeats,
//! truncation; for the pyramid the header and tile CRCs are usually recomputed so mutations get
//! past the checksum) and runs the parser and everything a caller then does with what it
//! returned. An input whose outcome (which error, on which field; or success) has not been
//! seen yet joins the pool, so the loop works its way past one check after another.
//!
//! Every execution is checked for:
//!
//! * **no panic** (caught, its message kept);
//! * **no hang**: each input's wall time is measured (over [`SLOW`] counts as a failure when a
//!   second run is slow too); a watchdog aborts the process after [`HUNG`], writing the input
//!   first;
//! * **no allocation beyond what the input justifies**: a counting global allocator measures
//!   the peak of live heap bytes during the execution (on the executing thread); more than
//!   [`ALLOC_FACTOR`] × the input's length + [`ALLOC_SLACK`] is a failure. A single request
//!   over [`ALLOC_HARD_CAP`] is refused (the process then aborts on the allocation error) after
//!   the input is written, so a 40-byte header asking for 40 GB is caught, not an OOM kill.
//!
//! Failing inputs are written to `target/tmp/fuzz-failures/`. The corpus (seeds from real
//! files, and every input that ever failed, each with a regression test below) is
//! `tests/fuzz_corpus/<target>/`; `write_seeds` (ignored) regenerates the seeds.
//!
//! `cargo test --test fuzz` runs a short, fixed-seed run of each target (CI). Longer:
//! `GLOBE_FUZZ_ITERS=1000000 cargo test --test fuzz -- --nocapture`, or `GLOBE_FUZZ_SECS=600`
//! (the same sequence, stopped after that long); `GLOBE_FUZZ_SEED=n` for another sequence,
//! `GLOBE_FUZZ_TARGET=name` (or a test name filter) for one target, `GLOBE_FUZZ_VERBOSE=1` for
//! every outcome seen. The dev profile's overflow checks are part of the net: keep it.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::collections::{BTreeMap, HashMap};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use globe::dem::ehdr::EhdrHeader;
use globe::dem::netcdf::NetcdfFile;
use globe::dem::pyramid::{Plane, Pyramid, Region};
use globe::dem::raster::BilinearSampler;
use globe::dem::{
    DemError, EhdrMosaic, EhdrRaster, GeoTiffRaster, HgtRaster, NetcdfRaster, RasterMosaic,
    RasterSource,
};
use globe::procedural::{Detail, DetailError, DetailParams, RoughnessMap};
use globe::stream::{MmapTileSource, TileKey, TileSource};

/// Peak live heap bytes one execution may reach, per byte of input…
const ALLOC_FACTOR: usize = 16;
/// …plus this much (error messages, small tables, the detail's relief map copy).
const ALLOC_SLACK: usize = 256 << 10;
/// A single allocation larger than this is refused outright (and the input written first).
const ALLOC_HARD_CAP: usize = 256 << 20;
/// An execution slower than this (twice) is a failure.
const SLOW: Duration = Duration::from_secs(2);
/// An execution still running after this is a hang: the watchdog writes it and aborts.
const HUNG: Duration = Duration::from_secs(30);
/// Inputs grow no larger than this.
const MAX_INPUT: usize = 64 << 10;
/// The pool (seeds plus inputs with a new outcome) holds at most this many inputs.
const MAX_POOL: usize = 512;
/// The fixed seed of the CI run.
const DEFAULT_SEED: u64 = 0x6c6f_6265_2016;

// ---------------------------------------------------------------------------------------------
// The allocation meter: a counting global allocator, per thread
// ---------------------------------------------------------------------------------------------

struct Meter;

thread_local! {
    /// Metering this thread (an execution is running on it).
    static METERING: Cell<bool> = const { Cell::new(false) };
    /// Live bytes allocated by this thread while metering (frees of older blocks subtract too).
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
    /// Set while the allocator itself writes an input out (its own allocations pass through).
    static BYPASS: Cell<bool> = const { Cell::new(false) };
    /// The input being executed on this thread, for the allocator's refusal.
    static CURRENT: Cell<*const Running> = const { Cell::new(std::ptr::null()) };
    /// Bytes the caller's own buffers may take on top of the input's budget: rows sized by a
    /// grid the parser accepted, whose size the target checked against the input first.
    static CALLER_BYTES: Cell<usize> = const { Cell::new(0) };
}

fn metering() -> bool {
    METERING.try_with(Cell::get).unwrap_or(false) && !BYPASS.try_with(Cell::get).unwrap_or(true)
}

fn count(delta: isize) {
    let _ = LIVE.try_with(|live| {
        let now = live.get() + delta;
        live.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

/// Whether a request of `size` bytes may go ahead; a refused one writes the input out first.
fn admit(size: usize) -> bool {
    if size <= ALLOC_HARD_CAP || !metering() {
        return true;
    }
    let _ = BYPASS.try_with(|b| b.set(true));
    let running = CURRENT.try_with(Cell::get).unwrap_or(std::ptr::null());
    if !running.is_null() {
        // SAFETY: `execute` sets CURRENT to a `Running` that outlives the execution.
        let running = unsafe { &*running };
        let saved = save_failure(running.target, &running.input, "over-allocation");
        eprintln!(
            "fuzz {}: one allocation of {size} bytes requested (hard cap {ALLOC_HARD_CAP}); \
             input written to {}; the process now aborts on the refused allocation",
            running.target,
            saved.display()
        );
    }
    let _ = BYPASS.try_with(|b| b.set(false));
    false
}

// SAFETY: forwards to `System`; the bookkeeping touches only const-initialised thread-locals
// without destructors (no allocation, no re-entry).
unsafe impl GlobalAlloc for Meter {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !admit(layout.size()) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() && metering() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !admit(layout.size()) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() && metering() {
            count(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        if metering() {
            count(-(layout.size() as isize));
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() && !admit(new_size) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() && metering() {
            count(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[global_allocator]
static METER: Meter = Meter;

// ---------------------------------------------------------------------------------------------
// Inputs and the corpus
// ---------------------------------------------------------------------------------------------

/// One input: the files a person would hand us, each a name suffix (`hdr`, `1.dem`, `cdf`, …)
/// and its bytes.
#[derive(Clone, Debug, PartialEq)]
struct Input {
    files: Vec<(String, Vec<u8>)>,
}

impl Input {
    fn len(&self) -> usize {
        self.files.iter().map(|(_, b)| b.len()).sum()
    }
}

fn corpus_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz_corpus")
        .join(target)
}

/// The file extensions a target reads (others, such as the `.aux.xml` GDAL leaves beside a
/// file it has read, are not part of an input).
fn extensions(target: &str) -> &'static [&'static str] {
    match target {
        "ehdr" => &["hdr", "bil", "dem", "flt", "bip", "bsq"],
        "netcdf" => &["nc", "cdf"],
        "pyramid" => &["globepyr"],
        "detail" => &["json"],
        "geotiff" => &["tif"],
        "hgt" => &["hgt"],
        _ => &[],
    }
}

/// The corpus of a target: files grouped by the part of their name before the first `.`
/// (`gtopo.1.hdr` and `gtopo.1.dem` are one input), in name order.
fn corpus(target: &str) -> Vec<(String, Input)> {
    let mut groups: BTreeMap<String, Vec<(String, Vec<u8>)>> = BTreeMap::new();
    let dir = corpus_dir(target);
    for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.expect("corpus entry").path();
        let name = path
            .file_name()
            .expect("name")
            .to_string_lossy()
            .into_owned();
        let ext = name.rsplit('.').next().unwrap_or_default();
        if !extensions(target).contains(&ext.to_ascii_lowercase().as_str()) {
            continue;
        }
        let (stem, suffix) = name.split_once('.').unwrap_or((&name, ""));
        let bytes = std::fs::read(&path).expect("corpus file");
        groups
            .entry(stem.to_string())
            .or_default()
            .push((suffix.to_string(), bytes));
    }
    groups
        .into_iter()
        .map(|(stem, mut files)| {
            files.sort();
            (stem, Input { files })
        })
        .collect()
}

/// The input named `stem` in a target's corpus.
fn corpus_input(target: &str, stem: &str) -> Input {
    corpus(target)
        .into_iter()
        .find(|(s, _)| s == stem)
        .unwrap_or_else(|| panic!("no input {stem} in tests/fuzz_corpus/{target}"))
        .1
}

fn failure_dir() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures")
}

/// Writes a failing input to `target/tmp/fuzz-failures/<target>-<kind>-<hash>.*`; returns the
/// first file's path.
fn save_failure(target: &str, input: &Input, kind: &str) -> PathBuf {
    let dir = failure_dir();
    let _ = std::fs::create_dir_all(&dir);
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for (suffix, bytes) in &input.files {
        for &b in suffix.as_bytes().iter().chain(bytes) {
            h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }
    let stem = format!("{target}-{kind}-{h:016x}");
    let mut first = dir.join(&stem);
    for (i, (suffix, bytes)) in input.files.iter().enumerate() {
        let path = dir.join(format!("{stem}.{suffix}"));
        let _ = std::fs::write(&path, bytes);
        if i == 0 {
            first = path;
        }
    }
    first
}

// ---------------------------------------------------------------------------------------------
// Executions: the properties
// ---------------------------------------------------------------------------------------------

/// What the watchdog and the allocator's refusal need to know about a running execution.
struct Running {
    target: &'static str,
    input: Arc<Input>,
    since: Instant,
}

/// Executions in flight, by thread, for the watchdog.
fn in_flight() -> &'static Mutex<HashMap<std::thread::ThreadId, Arc<Running>>> {
    static IN_FLIGHT: OnceLock<Mutex<HashMap<std::thread::ThreadId, Arc<Running>>>> =
        OnceLock::new();
    IN_FLIGHT.get_or_init(|| {
        std::thread::spawn(|| {
            loop {
                std::thread::sleep(Duration::from_millis(250));
                let hung = in_flight()
                    .lock()
                    .ok()
                    .and_then(|m| m.values().find(|r| r.since.elapsed() > HUNG).cloned());
                if let Some(r) = hung {
                    let saved = save_failure(r.target, &r.input, "hang");
                    eprintln!(
                        "fuzz {}: an input has run for more than {HUNG:?}: written to {}; \
                         aborting",
                        r.target,
                        saved.display()
                    );
                    std::process::abort();
                }
            }
        });
        Mutex::new(HashMap::new())
    })
}

thread_local! {
    /// The message of a panic caught during an execution on this thread.
    static PANIC: std::cell::RefCell<Option<String>> = const { std::cell::RefCell::new(None) };
}

/// Panics during executions are kept (message and place) instead of printed.
fn quiet_panics() {
    static HOOK: OnceLock<()> = OnceLock::new();
    HOOK.get_or_init(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if CURRENT.with(Cell::get).is_null() {
                default(info);
                return;
            }
            let message = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_default();
            let place = info
                .location()
                .map(|l| format!("{}:{}", l.file(), l.line()))
                .unwrap_or_default();
            PANIC.with(|p| *p.borrow_mut() = Some(format!("{message} at {place}")));
        }));
    });
}

/// One execution's result.
struct Exec {
    /// The outcome, coarsely: which error on which field, or what succeeded.
    signature: String,
    failure: Option<String>,
    elapsed: Duration,
    /// Peak live heap bytes above the start.
    peak: usize,
    /// The caller's buffers allowed on top of the input's budget.
    caller_bytes: usize,
    /// Peak live heap bytes the execution may reach.
    budget: usize,
}

fn run_once(target: &Target, input: &Arc<Input>) -> Exec {
    let running = Arc::new(Running {
        target: target.name,
        input: input.clone(),
        since: Instant::now(),
    });
    let me = std::thread::current().id();
    in_flight()
        .lock()
        .expect("in flight")
        .insert(me, running.clone());
    CURRENT.with(|c| c.set(Arc::as_ptr(&running)));
    LIVE.with(|l| l.set(0));
    PEAK.with(|p| p.set(0));
    CALLER_BYTES.with(|c| c.set(0));
    METERING.with(|m| m.set(true));
    let start = Instant::now();
    let result = catch_unwind(AssertUnwindSafe(|| (target.run)(input)));
    let elapsed = start.elapsed();
    METERING.with(|m| m.set(false));
    CURRENT.with(|c| c.set(std::ptr::null()));
    in_flight().lock().expect("in flight").remove(&me);
    let peak = PEAK.with(Cell::get).max(0) as usize;
    let (signature, failure) = match result {
        Ok(signature) => (signature, None),
        Err(_) => {
            let message = PANIC.with(|p| p.borrow_mut().take()).unwrap_or_default();
            ("panic".to_string(), Some(format!("panic: {message}")))
        }
    };
    Exec {
        signature,
        failure,
        elapsed,
        peak,
        caller_bytes: CALLER_BYTES.with(Cell::get),
        budget: 0,
    }
}

/// Runs one input and checks the three properties.
fn execute(target: &Target, input: &Arc<Input>) -> Exec {
    let mut exec = run_once(target, input);
    let budget = ALLOC_FACTOR * input.len() + ALLOC_SLACK + exec.caller_bytes;
    exec.budget = budget;
    if exec.failure.is_none() && exec.peak > budget {
        exec.failure = Some(format!(
            "over-allocation: peak {} bytes live for a {}-byte input (budget {budget}, of which \
             {} for the caller's rows)",
            exec.peak,
            input.len(),
            exec.caller_bytes
        ));
    }
    if exec.failure.is_none() && exec.elapsed > SLOW {
        // A loaded machine can stall one run; a slow input is slow again.
        let again = run_once(target, input);
        if again.elapsed > SLOW {
            exec.failure = Some(format!(
                "slow: {:?} and {:?} (bound {SLOW:?})",
                exec.elapsed, again.elapsed
            ));
        }
    }
    exec
}

// ---------------------------------------------------------------------------------------------
// The deterministic generator and the mutations
// ---------------------------------------------------------------------------------------------

/// SplitMix64: small, fast, and the same sequence everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (0 for n = 0).
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }

    /// True with probability 1/n.
    fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// What the mutations know of one file: its byte order, how long its header (the hot region)
/// is, and where the numeric fields of a binary header lie (offset, width), as far as the
/// header could be walked.
struct Shape {
    numbers: Numbers,
    hot: usize,
    fields: Vec<Field>,
}

/// A numeric field of a binary header: offset, width in bytes, and kind (fields of one kind,
/// such as dimension lengths, are alike: sizes multiply, so they are often set together).
type Field = (usize, usize, u8);

/// How a format stores its numbers, for the integer-boundary mutation.
#[derive(Clone, Copy, PartialEq)]
enum Numbers {
    BigEndian,
    LittleEndian,
    Text,
}

/// Integers at the edges of the ranges headers use.
const INTERESTING: [u64; 22] = [
    0,
    1,
    2,
    3,
    4,
    7,
    8,
    0x10,
    0x7f,
    0x80,
    0xff,
    0x100,
    0x7fff,
    0x8000,
    0xffff,
    0x1_0000,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    0x1_0000_0000,
    0x7fff_ffff_ffff_ffff,
    0xffff_ffff_ffff_ffff,
];

/// Floating-point values at the edges of what headers' `f64` fields hold (degrees, metres).
const INTERESTING_F64: [f64; 20] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e-300,
    f64::MIN_POSITIVE,
    5e-324,
    1e300,
    f64::MAX,
    f64::MIN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
    90.0,
    -90.0,
    180.0,
    360.0,
    -360.0,
    32767.0,
];

/// Numbers at the edges of what text headers and JSON hold.
const INTERESTING_TEXT: [&str; 34] = [
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "0.5",
    "-0.5",
    "90",
    "-90",
    "180",
    "360",
    "-360",
    "361",
    "1e-12",
    "1e-320",
    "1e308",
    "-1e308",
    "1e309",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "-2147483649",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "9223372036854775808",
    "18446744073709551616",
    "99999999999999999999999999999",
    "0.000000000000000000000000000001",
];

/// A position in `0..len`, half the time within the first `hot` bytes (the header).
fn position(rng: &mut Rng, len: usize, hot: usize) -> usize {
    if hot > 0 && rng.one_in(2) {
        rng.below(hot.min(len))
    } else {
        rng.below(len)
    }
}

/// One mutation of `b` (`donor`: another input's bytes, for splices).
fn mutate_bytes(rng: &mut Rng, b: &mut Vec<u8>, shape: &Shape, donor: &[u8], dictionary: &[&str]) {
    let (numbers, hot) = (shape.numbers, shape.hot);
    let len = b.len();
    let mut op = rng.below(13);
    if op == 12 && dictionary.is_empty() {
        op = 3;
    }
    if numbers == Numbers::Text && matches!(op, 0 | 1 | 8) && !rng.one_in(3) {
        op = 6; // in text, numbers are what the checks are about
    }
    match op {
        // Flip one to four bits.
        0 | 1 if len > 0 => {
            for _ in 0..1 + rng.below(4) {
                let at = position(rng, len, hot);
                b[at] ^= 1 << rng.below(8);
            }
        }
        // A byte that often means something.
        2 if len > 0 => {
            let at = position(rng, len, hot);
            b[at] = *rng.pick(&[
                0, 1, 0x7f, 0x80, 0xff, b'0', b'9', b'-', b' ', b'\n', b'.', b'e', b'"', b'{',
            ]);
        }
        // Insert random bytes or a copy of a chunk.
        3 => {
            let at = position(rng, len + 1, hot);
            let chunk: Vec<u8> = if len > 0 && rng.one_in(2) {
                let from = rng.below(len);
                b[from..(from + 1 + rng.below(32)).min(len)].to_vec()
            } else {
                (0..1 + rng.below(16)).map(|_| rng.next() as u8).collect()
            };
            b.splice(at..at, chunk);
        }
        // Delete a range.
        4 if len > 0 => {
            let at = position(rng, len, hot);
            let most = if rng.one_in(4) { 256 } else { 8 };
            let end = (at + 1 + rng.below(most)).min(len);
            b.drain(at..end);
        }
        // Splice in a range of another input.
        5 if len > 0 && !donor.is_empty() => {
            let at = position(rng, len, hot);
            let from = rng.below(donor.len());
            let n = 1 + rng.below(64);
            let chunk = &donor[from..(from + n).min(donor.len())];
            let end = (at + chunk.len()).min(len);
            b.splice(at..end, chunk.iter().copied());
        }
        // An integer at the edge of a range, over a field.
        6 | 7 if numbers != Numbers::Text && len > 0 => {
            let width = *rng.pick(&[1usize, 2, 4, 4, 4, 8, 8]);
            let mut at = position(rng, len, hot);
            if !rng.one_in(4) {
                at -= at % width;
            }
            let field = interesting_field(rng, width, numbers);
            if rng.one_in(3) {
                // Inserted: one more list entry, count or dimension id.
                b.splice(at..at, field);
            } else {
                let end = (at + width).min(len);
                b[at..end].copy_from_slice(&field[..end - at]);
            }
        }
        // A number in text replaced by one at an edge.
        6 | 7 => {
            let spans = number_spans(b);
            if spans.is_empty() {
                let at = position(rng, len + 1, hot);
                b.splice(at..at, rng.pick(&INTERESTING_TEXT).bytes());
            } else {
                let (s, e) = *rng.pick(&spans);
                let old = std::str::from_utf8(&b[s..e])
                    .ok()
                    .and_then(|t| t.parse::<f64>().ok());
                let new = match old {
                    // A value near the old one: ranges are checked at their edges.
                    Some(v) if rng.one_in(2) => {
                        let f = *rng.pick(&[0.0, 0.5, 0.999, 1.001, 2.0, 10.0, -1.0, 1e-3, 1e3]);
                        format!("{}", v * f)
                    }
                    _ => rng.pick(&INTERESTING_TEXT).to_string(),
                };
                b.splice(s..e, new.bytes());
            }
        }
        // Small arithmetic on a word.
        8 if len >= 4 => {
            let at = position(rng, len - 3, hot) & !3;
            let at = at.min(len - 4);
            let mut w = [0u8; 4];
            w.copy_from_slice(&b[at..at + 4]);
            let delta = rng.below(33) as i32 - 16;
            let v = if numbers == Numbers::BigEndian {
                u32::from_be_bytes(w)
                    .wrapping_add(delta as u32)
                    .to_be_bytes()
            } else {
                u32::from_le_bytes(w)
                    .wrapping_add(delta as u32)
                    .to_le_bytes()
            };
            b[at..at + 4].copy_from_slice(&v);
        }
        // Repeat a chunk (lines, records, list entries).
        9 if len > 0 => {
            let from = position(rng, len, hot);
            let chunk = b[from..(from + 1 + rng.below(96)).min(len)].to_vec();
            let most = if rng.one_in(8) { 64 } else { 4 };
            let times = 1 + rng.below(most);
            for _ in 0..times {
                b.splice(from..from, chunk.iter().copied());
            }
        }
        // A word of the format (a key, a keyword, a name): over a word of the input, or
        // inserted.
        12 => {
            let word = rng.pick(dictionary).as_bytes();
            let at = position(rng, len + 1, hot);
            let end = if rng.one_in(2) {
                let word_end = b[at..]
                    .iter()
                    .position(|c| !c.is_ascii_alphanumeric() && *c != b'_')
                    .map_or(len, |p| at + p);
                if numbers == Numbers::Text {
                    word_end
                } else {
                    (at + word.len()).min(len)
                }
            } else {
                at
            };
            b.splice(at..end, word.iter().copied());
        }
        // Truncate.
        10 if len > 0 => {
            let at = position(rng, len, hot);
            b.truncate(at);
        }
        // Text: drop or duplicate a line.
        _ if numbers == Numbers::Text && len > 0 => {
            let starts: Vec<usize> = std::iter::once(0)
                .chain(
                    b.iter()
                        .enumerate()
                        .filter(|(_, c)| **c == b'\n')
                        .map(|(i, _)| i + 1),
                )
                .filter(|&i| i < len)
                .collect();
            let s = *rng.pick(&starts);
            let e = b[s..]
                .iter()
                .position(|&c| c == b'\n')
                .map_or(len, |p| s + p + 1);
            if rng.one_in(2) {
                b.drain(s..e);
            } else {
                let line = b[s..e].to_vec();
                b.splice(s..s, line);
            }
        }
        _ => {
            // Whatever else: replace a byte at random.
            if len > 0 {
                let at = rng.below(len);
                b[at] = rng.next() as u8;
            } else {
                b.push(rng.next() as u8);
            }
        }
    }
    b.truncate(MAX_INPUT);
}

/// `width` bytes of an integer (or, for 8 bytes, a float) at the edge of a range, usually in
/// the format's byte order.
fn interesting_field(rng: &mut Rng, width: usize, numbers: Numbers) -> Vec<u8> {
    let mut v = *rng.pick(&INTERESTING);
    if rng.one_in(3) {
        v = v.wrapping_neg();
    }
    if rng.one_in(4) {
        v = v.wrapping_add(rng.below(5) as u64).wrapping_sub(2);
    }
    if width == 8 && rng.one_in(2) {
        v = rng.pick(&INTERESTING_F64).to_bits();
    }
    let mut field = v.to_le_bytes()[..width].to_vec();
    let big = match numbers {
        Numbers::BigEndian => !rng.one_in(5),
        _ => rng.one_in(5),
    };
    if big {
        field.reverse();
    }
    field
}

/// One field of a binary header (from the format's field map) set to a value at an edge, or
/// nudged by a little; sometimes several fields of its kind set to the same value.
fn mutate_field(rng: &mut Rng, b: &mut [u8], shape: &Shape) {
    let (at, width, kind) = *rng.pick(&shape.fields);
    let Some(field) = b.get(at..at + width) else {
        return;
    };
    let big = shape.numbers == Numbers::BigEndian;
    let new = if rng.one_in(3) && width >= 4 {
        let mut word = [0u8; 8];
        word[..width].copy_from_slice(field);
        if big {
            word[..width].reverse();
        }
        let v = u64::from_le_bytes(word)
            .wrapping_add(rng.below(9) as u64)
            .wrapping_sub(4);
        let mut new = v.to_le_bytes()[..width].to_vec();
        if big {
            new.reverse();
        }
        new
    } else {
        interesting_field(rng, width, shape.numbers)
    };
    let mut targets = vec![at];
    if rng.one_in(4) {
        targets.extend(
            shape
                .fields
                .iter()
                .filter(|f| f.2 == kind && f.1 == width && f.0 != at)
                .map(|f| f.0)
                .filter(|_| rng.one_in(2)),
        );
    }
    for at in targets {
        if let Some(field) = b.get_mut(at..at + width) {
            field.copy_from_slice(&new);
        }
    }
}

/// Byte ranges of numbers (`-1.5e3`, `nan`, …) in text.
fn number_spans(t: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < t.len() {
        let starts =
            t[i].is_ascii_digit() || (t[i] == b'-' && t.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts && (i == 0 || !t[i - 1].is_ascii_alphanumeric()) {
            let s = i;
            i += 1;
            while i < t.len()
                && (t[i].is_ascii_alphanumeric() || matches!(t[i], b'.' | b'+' | b'-'))
            {
                i += 1;
            }
            spans.push((s, i));
        } else {
            i += 1;
        }
    }
    spans
}

/// A mutant of `parent`: a few stacked mutations of one (sometimes every) file, then the
/// target's fix-up.
fn mutant(rng: &mut Rng, target: &Target, parent: &Input, donor: &Input) -> Input {
    let mut input = parent.clone();
    let stacked = if rng.one_in(16) {
        8 + rng.below(9)
    } else {
        1 + rng.below(4)
    };
    let nfiles = input.files.len();
    let every = rng.one_in(8);
    let chosen = rng.below(nfiles);
    for (i, (suffix, bytes)) in input.files.iter_mut().enumerate() {
        if !(every || i == chosen) {
            continue;
        }
        let shape = (target.layout)(suffix, bytes);
        let donor_bytes = donor
            .files
            .iter()
            .find(|(s, _)| s == suffix)
            .or(donor.files.first())
            .map_or(&[][..], |(_, b)| b.as_slice());
        for _ in 0..stacked {
            if !shape.fields.is_empty() && rng.one_in(3) {
                mutate_field(rng, bytes, &shape);
            } else {
                mutate_bytes(rng, bytes, &shape, donor_bytes, target.dictionary);
            }
        }
    }
    if nfiles > 1 && rng.one_in(8) {
        same_value_everywhere(rng, &mut input);
    }
    if let Some(fix) = target.fix_up {
        fix(rng, &mut input);
    }
    input
}

/// In every text file that has the key of a `KEY value` line of one of them, gives that key
/// the same new value (tiles of a mosaic must agree on XDIM, YDIM and their lattice, so a
/// change that matters often has to be made in all of them at once).
fn same_value_everywhere(rng: &mut Rng, input: &mut Input) {
    let lines: Vec<String> = input
        .files
        .iter()
        .flat_map(|(_, b)| {
            String::from_utf8_lossy(b)
                .lines()
                .map(str::to_string)
                .collect::<Vec<_>>()
        })
        .filter(|l| l.split_whitespace().count() == 2)
        .collect();
    if lines.is_empty() {
        return;
    }
    let key = rng
        .pick(&lines)
        .split_whitespace()
        .next()
        .unwrap_or_default()
        .to_string();
    let value = match rng.below(3) {
        0 => rng.pick(&INTERESTING_TEXT).to_string(),
        1 => format!("{:e}", 10f64.powi(-(rng.below(13) as i32))),
        _ => format!(
            "{}",
            (rng.below(721) as f64 - 360.0) / *rng.pick(&[1.0, 2.0, 12.0, 120.0])
        ),
    };
    for (_, b) in &mut input.files {
        let text = String::from_utf8_lossy(b);
        if !text
            .lines()
            .any(|l| l.split_whitespace().next() == Some(&key))
        {
            continue;
        }
        let edited: Vec<String> = text
            .lines()
            .map(|l| {
                if l.split_whitespace().next() == Some(&key) {
                    format!("{key} {value}")
                } else {
                    l.to_string()
                }
            })
            .collect();
        *b = (edited.join("\n") + "\n").into_bytes();
    }
}

// ---------------------------------------------------------------------------------------------
// The loop
// ---------------------------------------------------------------------------------------------

struct Target {
    name: &'static str,
    /// Executions of the CI run.
    ci_iters: usize,
    /// Runs the parser and what a caller does with its result; returns the outcome's signature.
    run: fn(&Input) -> String,
    /// How a file of the input stores numbers, where its header's fields are.
    layout: fn(&str, &[u8]) -> Shape,
    /// Applied after mutating (recompute checksums, so mutations reach the checks behind them).
    fix_up: Option<fn(&mut Rng, &mut Input)>,
    /// Words of the format the mutations write in.
    dictionary: &'static [&'static str],
}

/// What one fuzzing run did.
#[derive(Debug)]
struct Report {
    execs: usize,
    elapsed: Duration,
    pool: usize,
    signatures: usize,
    accepted: usize,
    failures: Vec<String>,
    slowest: Duration,
    /// The largest share of its allocation budget an execution used, and its peak in bytes.
    worst_alloc: (f64, usize),
}

/// How long a run lasts: a number of mutants (the CI run, `GLOBE_FUZZ_ITERS`), or a time
/// (`GLOBE_FUZZ_SECS`: the same sequence, stopped when the time is up).
#[derive(Clone, Copy, Debug)]
enum Length {
    Iterations(usize),
    Time(Duration),
}

fn env_usize(name: &str) -> Option<usize> {
    std::env::var(name).ok().map(|v| {
        v.replace('_', "")
            .parse()
            .unwrap_or_else(|_| panic!("{name}={v:?}: expected a whole number"))
    })
}

fn fuzz(target: &Target, length: Length, seed: u64) -> Report {
    quiet_panics();
    let mut rng = Rng(seed ^ fxhash(target.name));
    let mut pool: Vec<Arc<Input>> = corpus(target.name)
        .into_iter()
        .map(|(_, i)| Arc::new(i))
        .collect();
    assert!(!pool.is_empty(), "no corpus for {}", target.name);
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut report = Report {
        execs: 0,
        elapsed: Duration::ZERO,
        pool: 0,
        signatures: 0,
        accepted: 0,
        failures: Vec::new(),
        slowest: Duration::ZERO,
        worst_alloc: (0.0, 0),
    };
    let start = Instant::now();
    let seeds = pool.clone();
    let iters = match length {
        Length::Iterations(n) => n,
        Length::Time(_) => usize::MAX - seeds.len(),
    };
    for (i, input) in seeds
        .iter()
        .chain(std::iter::repeat_n(&seeds[0], iters))
        .enumerate()
    {
        if let Length::Time(limit) = length
            && i % 256 == 0
            && start.elapsed() > limit
        {
            break;
        }
        let input = if i < seeds.len() {
            input.clone()
        } else {
            // Half the time a seed: most of the pool is inputs that fail early, and a valid
            // file mutated is what reaches the deep checks.
            let parent = if rng.one_in(2) {
                seeds[rng.below(seeds.len())].clone()
            } else {
                pool[rng.below(pool.len())].clone()
            };
            let donor = pool[rng.below(pool.len())].clone();
            Arc::new(mutant(&mut rng, target, &parent, &donor))
        };
        let exec = execute(target, &input);
        report.execs += 1;
        report.slowest = report.slowest.max(exec.elapsed);
        let share = exec.peak as f64 / exec.budget as f64;
        if share > report.worst_alloc.0 {
            report.worst_alloc = (share, exec.peak);
        }
        if exec.signature.starts_with("ok") {
            report.accepted += 1;
        }
        if let Some(failure) = exec.failure {
            let kind = failure.split(':').next().unwrap_or("failure").to_string();
            let saved = save_failure(target.name, &input, &kind);
            report
                .failures
                .push(format!("{failure} (input: {})", saved.display()));
            if report.failures.len() >= 20 {
                break;
            }
            continue;
        }
        let count = seen.entry(exec.signature).or_default();
        *count += 1;
        if *count == 1 && i >= seeds.len() {
            if pool.len() < MAX_POOL {
                pool.push(input);
            } else {
                // Full: the newcomer takes a random place after the seeds.
                let at = seeds.len() + rng.below(MAX_POOL - seeds.len());
                pool[at] = input;
            }
        }
    }
    report.elapsed = start.elapsed();
    report.pool = pool.len();
    report.signatures = seen.len();
    if std::env::var_os("GLOBE_FUZZ_VERBOSE").is_some() {
        let mut counts: Vec<_> = seen.iter().collect();
        counts.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
        for (signature, n) in counts {
            println!("  {n:>8}  {signature}");
        }
    }
    println!(
        "fuzz {}: {} executions in {:.2} s ({:.0}/s), {} accepted by the parser, {} outcomes, \
         pool {}, slowest {:.1} ms, peak heap at most {:.0} % of the budget ({} bytes), {} \
         failures",
        target.name,
        report.execs,
        report.elapsed.as_secs_f64(),
        report.execs as f64 / report.elapsed.as_secs_f64(),
        report.accepted,
        report.signatures,
        report.pool,
        report.slowest.as_secs_f64() * 1e3,
        100.0 * report.worst_alloc.0,
        report.worst_alloc.1,
        report.failures.len()
    );
    report
}

fn fxhash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// The fuzz test of one target: the CI run, or `GLOBE_FUZZ_ITERS` executions.
fn fuzz_target(target: &Target) {
    if let Ok(only) = std::env::var("GLOBE_FUZZ_TARGET")
        && only != target.name
    {
        return;
    }
    let length = match (env_usize("GLOBE_FUZZ_SECS"), env_usize("GLOBE_FUZZ_ITERS")) {
        (Some(secs), _) => Length::Time(Duration::from_secs(secs as u64)),
        (None, iters) => Length::Iterations(iters.unwrap_or(target.ci_iters)),
    };
    let seed = env_usize("GLOBE_FUZZ_SEED").map_or(DEFAULT_SEED, |s| s as u64);
    let report = fuzz(target, length, seed);
    assert!(
        report.failures.is_empty(),
        "fuzz {}: {} failing inputs:\n{}",
        target.name,
        report.failures.len(),
        report.failures.join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// Outcome signatures
// ---------------------------------------------------------------------------------------------

/// Text with numbers (`-1.5e-3`, `0x1f`, `NaN`, `inf`) and quoted names replaced by `#`, so
/// that one check gives one signature whatever the values.
fn shape(s: &str) -> String {
    let mut unquoted = String::new();
    let mut quote = None;
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        match quote {
            Some(_) if c == '\\' => {
                chars.next(); // an escaped character of a quoted name
            }
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '"' || c == '`' => {
                quote = Some(c);
                unquoted.push('#');
            }
            None => unquoted.push(c),
        }
    }
    let mut out = String::new();
    for word in unquoted.split_whitespace() {
        let word = word.trim_matches(|c: char| matches!(c, ',' | ';' | ':' | '(' | ')'));
        let numeric = word.chars().any(|c| c.is_ascii_digit())
            || ["nan", "inf", "-inf"].contains(&word.to_ascii_lowercase().as_str());
        if !out.is_empty() {
            out.push(' ');
        }
        out.push_str(if numeric { "#" } else { word });
    }
    out
}

/// Which check an error comes from: its kind and field, or its message's first words.
fn dem_signature(e: &DemError) -> String {
    let words = |m: &str| shape(&m.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
    match e {
        DemError::Header { field, message, .. } => {
            format!("header {} {}", shape(field), words(message))
        }
        DemError::Data { message, .. } => format!("data {}", words(message)),
        DemError::Truncated { what, .. } => format!("truncated {}", words(what)),
        DemError::TileChecksum { .. } => "tile checksum".into(),
        DemError::Missing { message, .. } => format!("missing {}", words(message)),
        DemError::Io { .. } => "io".into(),
        other => format!("other {}", words(&other.to_string())),
    }
}

fn detail_signature(e: &DetailError) -> String {
    match e {
        DetailError::Parse { message, .. } => {
            // Names in serde's messages are quoted raw (a backtick may be part of one): keep
            // what comes before the first quote.
            let message = message.split(['`', '"']).next().unwrap_or_default();
            let message = message.split(" at line").next().unwrap_or_default();
            let words: Vec<&str> = message.split_whitespace().take(3).collect();
            format!("parse {}", shape(&words.join(" ")))
        }
        DetailError::Range { field, .. } => format!("range {field}"),
        other => format!("other {}", shape(&other.to_string())),
    }
}

// ---------------------------------------------------------------------------------------------
// What a caller does with a parsed raster (the importer reads every row; the tools sample)
// ---------------------------------------------------------------------------------------------

/// Points on and off any grid: corners of the globe, the antimeridian, NaN, far outside.
const PROBES: [(f64, f64); 9] = [
    (0.0, 0.0),
    (45.65, 10.65),
    (90.0, 180.0),
    (-90.0, -180.0),
    (-33.4, 359.99),
    (89.999, -0.001),
    (91.0, 0.0),
    (f64::NAN, 0.0),
    (0.0, f64::INFINITY),
];

/// Reads every row (as the pyramid builder does) and samples at the probes and the grid's own
/// corners. Row reads stop at the first error (a bad FLOAT sample ends an import too). The
/// caller checked the grid against the input; the rows it needs (one here, four in the
/// sampler's cache) are allowed on top of the input's budget.
fn exercise_source(src: &dyn RasterSource) {
    let g = src.grid();
    CALLER_BYTES.with(|c| c.set(c.get() + 5 * 4 * g.cols + 1024));
    let _ = src.describe();
    let mut row = vec![0f32; g.cols];
    for r in 0..g.rows {
        if src.read_row(r, &mut row).is_err() {
            break;
        }
    }
    let _ = src.read_row(g.rows, &mut row);
    let mut sampler = BilinearSampler::new(src);
    let corners = [
        (g.lat0_deg, g.lon0_deg),
        (
            g.lat_of_row(g.rows as f64 - 1.0),
            g.lon_of_col(g.cols as f64 - 1.0),
        ),
        (g.lat_of_row(0.5), g.lon_of_col(0.5)),
    ];
    for (lat, lon) in PROBES.iter().chain(&corners) {
        let _ = sampler.sample(*lat, *lon);
        let _ = g.row_col_of(*lat, *lon);
    }
}

fn exercise_ehdr(r: &EhdrRaster) {
    exercise_source(r);
    let h = r.header();
    let _ = (
        r.value(0, 0),
        r.value(h.nrows - 1, h.ncols - 1),
        r.value(h.nrows, 0),
    );
    let g = r.grid();
    let corners = [
        (g.lat0_deg, g.lon0_deg),
        (
            g.lat_of_row(g.rows as f64 - 0.5),
            g.lon_of_col(g.cols as f64 - 0.5),
        ),
    ];
    for (lat, lon) in PROBES.iter().chain(&corners) {
        let _ = r.pixel_of(*lat, *lon);
        let _ = r.sample_nearest(*lat, *lon);
        let _ = r.sample_bilinear(*lat, *lon);
    }
}

fn exercise_mosaic(m: &EhdrMosaic) {
    exercise_source(m);
    let g = m.grid();
    let _ = (m.value(0, 0), m.value(g.rows - 1, g.cols - 1));
    for (lat, lon) in PROBES {
        let _ = m.pixel_of(lat, lon);
        let _ = m.sample_nearest(lat, lon);
        let _ = m.sample_bilinear(lat, lon);
    }
}

// ---------------------------------------------------------------------------------------------
// The targets
// ---------------------------------------------------------------------------------------------

/// EHdr: each `*hdr` file with the data file of the same name (`hdr` + `bil`, or `1.hdr` +
/// `1.dem`, …): the header alone, the raster, and the mosaic of all that open.
fn run_ehdr(input: &Input) -> String {
    let mut signature = Vec::new();
    let mut rasters = Vec::new();
    for (suffix, header) in &input.files {
        let Some(prefix) = suffix.strip_suffix("hdr") else {
            continue;
        };
        let Some((data_suffix, data)) = input
            .files
            .iter()
            .find(|(s, _)| s.starts_with(prefix) && !s.ends_with("hdr"))
        else {
            continue;
        };
        let hdr_path = format!("fuzz.{suffix}");
        let text = String::from_utf8_lossy(header);
        let _ = EhdrHeader::parse(&text, Path::new(&hdr_path));
        match EhdrRaster::from_bytes(
            header,
            &hdr_path,
            data.clone(),
            format!("fuzz.{data_suffix}"),
        ) {
            Ok(r) => {
                let h = r.header();
                let pixels = h.nrows as u64 * h.ncols as u64;
                assert!(pixels * h.sample_type.bytes() as u64 <= data.len() as u64);
                exercise_ehdr(&r);
                signature.push(format!(
                    "ok {:?} {:?}",
                    r.header().sample_type,
                    r.header().layout
                ));
                rasters.push(r);
            }
            Err(e) => signature.push(dem_signature(&e)),
        }
    }
    if rasters.len() >= 2 {
        let tile_pixels: usize = rasters
            .iter()
            .map(|r| r.header().nrows * r.header().ncols)
            .sum();
        match EhdrMosaic::from_rasters(rasters, "fuzz mosaic") {
            Ok(m) => {
                let g = m.grid();
                assert!(
                    g.rows as u128 * g.cols as u128
                        <= (EhdrMosaic::MAX_BOUNDING_FACTOR * tile_pixels) as u128,
                    "a mosaic of {tile_pixels} pixels has a {} × {} grid",
                    g.cols,
                    g.rows
                );
                exercise_mosaic(&m);
                signature.push("mosaic ok".into());
            }
            Err(e) => signature.push(format!("mosaic {}", dem_signature(&e))),
        }
    }
    signature.join(" | ")
}

/// netCDF-3: the header and every variable's values, then the CF raster adaptor.
fn run_netcdf(input: &Input) -> String {
    let (_, bytes) = &input.files[0];
    let nc = match NetcdfFile::from_bytes(bytes.clone(), "fuzz.nc") {
        Ok(nc) => nc,
        Err(e) => return dem_signature(&e),
    };
    let _ = format!("{nc:?}");
    for v in nc.variables() {
        for a in &v.attributes {
            let _ = (a.value.to_string(), a.value.as_f64s(), a.value.first_f64());
        }
        let _ = nc.shape(&v.name);
        if let Ok(n) = nc.len(&v.name) {
            let _ = nc.read_f64(&v.name);
            let mut some = [0.0; 3];
            let _ = nc.read_f64_into(&v.name, n.saturating_sub(2), &mut some);
        }
    }
    match NetcdfRaster::from_file(nc, None) {
        Ok(r) => {
            let g = r.grid();
            assert!(g.rows as u64 * g.cols as u64 <= bytes.len() as u64);
            exercise_source(&r);
            let _ = (
                r.value(0, 0),
                r.value(g.rows - 1, g.cols - 1),
                r.value(g.rows, 0),
            );
            let _ = (r.notes(), r.variable_name(), format!("{r:?}"));
            format!("ok {} notes", r.notes().len())
        }
        Err(e) => format!("raster {}", dem_signature(&e)),
    }
}

/// GeoTIFF: each `tif` file alone (open, every row, samples), then the mosaic of those that
/// open. A compressed raster decodes one band of chunks at a time; what it holds is allowed on
/// top of the input's budget once the target has checked that the file's bytes justify it (no
/// codec expands more than 1400 times).
fn run_geotiff(input: &Input) -> String {
    let mut signature = Vec::new();
    let mut opened: Vec<(String, Box<dyn RasterSource>)> = Vec::new();
    for (i, (suffix, bytes)) in input.files.iter().enumerate() {
        if !suffix.ends_with("tif") {
            continue;
        }
        match GeoTiffRaster::from_bytes(bytes.clone(), format!("fuzz{i}.{suffix}")) {
            Ok(r) => {
                let (cw, ch) = r.chunk_size();
                let chunk = cw * ch * r.sample_type().bytes();
                assert!(
                    r.band_bytes() as u64 <= 2 * 1400 * bytes.len() as u64,
                    "a {}-byte file holds a decoded band of {} bytes",
                    bytes.len(),
                    r.band_bytes()
                );
                if r.band_bytes() > 0 {
                    CALLER_BYTES.with(|c| c.set(c.get() + r.band_bytes() + 2 * chunk));
                }
                exercise_source(&r);
                let _ = (r.crs(), r.nodata(), r.pixel_is_point(), r.has_overviews());
                signature.push(format!(
                    "ok {:?} {} {}",
                    r.sample_type(),
                    r.compression(),
                    if r.tiled() { "tiles" } else { "strips" }
                ));
                opened.push((format!("fuzz{i}"), Box::new(r)));
            }
            Err(e) => signature.push(dem_signature(&e)),
        }
    }
    if opened.len() >= 2 {
        let tile_pixels: usize = opened
            .iter()
            .map(|(_, r)| r.grid().rows * r.grid().cols)
            .sum();
        match RasterMosaic::from_sources(opened, "fuzz mosaic") {
            Ok(m) => {
                let g = m.grid();
                assert!(
                    g.rows as u128 * g.cols as u128
                        <= (RasterMosaic::MAX_BOUNDING_FACTOR * tile_pixels) as u128
                );
                exercise_source(&m);
                signature.push("mosaic ok".into());
            }
            Err(e) => signature.push(format!("mosaic {}", dem_signature(&e))),
        }
    }
    signature.join(" | ")
}

/// SRTM `.hgt`: a tile's name is its only header and its size its only field, and a real tile
/// (2.9 MB) is far over the fuzzer's input size. So an input is text and bytes: its first
/// line(s) the file names, then `@`, a mode byte and data: mode 1 repeats the data to a
/// 1201 × 1201 tile (that buffer is the caller's, allowed on top of the budget), any other
/// mode hands the data over as it is (the size check).
fn run_hgt(input: &Input) -> String {
    let (_, bytes) = &input.files[0];
    let at = bytes.iter().position(|&b| b == b'@').unwrap_or(bytes.len());
    let names = String::from_utf8_lossy(&bytes[..at]).into_owned();
    let rest = bytes.get(at + 1..).unwrap_or_default();
    let (mode, data) = rest.split_first().map_or((0, &[][..]), |(m, d)| (*m, d));
    let tile = if mode == 1 && !data.is_empty() {
        let n = 1201 * 1201 * 2;
        CALLER_BYTES.with(|c| c.set(c.get() + 3 * n));
        data.iter().copied().cycle().take(n).collect::<Vec<u8>>()
    } else {
        data.to_vec()
    };
    let mut signature = Vec::new();
    let mut opened: Vec<(String, Box<dyn RasterSource>)> = Vec::new();
    for name in names.lines().take(2) {
        let _ = globe::dem::hgt::corner_of_name(Path::new(name));
        match HgtRaster::from_bytes(tile.clone(), name) {
            Ok(t) => {
                exercise_source(&t);
                let _ = (t.value(0, 0), t.value(1200, 1200), t.value(1201, 0));
                signature.push("ok".to_string());
                opened.push((name.to_string(), Box::new(t)));
            }
            Err(e) => signature.push(dem_signature(&e)),
        }
    }
    if opened.len() == 2 {
        match RasterMosaic::from_sources(opened, "fuzz mosaic") {
            Ok(m) => {
                let g = m.grid();
                CALLER_BYTES.with(|c| c.set(c.get() + 6 * 4 * g.cols));
                exercise_source(&m);
                signature.push("mosaic ok".into());
            }
            Err(e) => signature.push(format!("mosaic {}", dem_signature(&e))),
        }
    }
    signature.join(" | ")
}

/// The pyramid: open (header, level table, tile index, length), then every tile as the
/// streamer reads it, `verify`, samples and bounds at every level.
fn run_pyramid(input: &Input) -> String {
    let (_, bytes) = &input.files[0];
    let p = match Pyramid::from_bytes(bytes.clone(), "fuzz.globepyr") {
        Ok(p) => Arc::new(p),
        Err(e) => return dem_signature(&e),
    };
    let info = p.info();
    let _ = info.to_string();
    assert!(
        info.min_m.is_finite() && info.min_m <= info.max_m && info.max_m.is_finite(),
        "height range {} … {} m",
        info.min_m,
        info.max_m
    );
    // Codes are only vouched for by `verify` (or `tile_verified`, tile by tile).
    let verified = p.verify().is_ok();
    let _ = (p.check_length(), p.level_for_spacing(1.0));
    let source = MmapTileSource::new(p.clone());
    for (level, l) in p.levels().iter().enumerate() {
        for ty in 0..l.tiles_y {
            for tx in 0..l.tiles_x {
                if let Ok(t) = p.tile(level, tx, ty) {
                    let _ = t.get_m(Plane::Max, t.valid_cols - 1, t.valid_rows - 1);
                }
                let key = TileKey {
                    level: level as u32,
                    tx: tx as u32,
                    ty: ty as u32,
                };
                let _ = source.read(key);
            }
        }
        let _ = p.tile(level, l.tiles_x, 0);
        for plane in [Plane::Avg, Plane::Min, Plane::Max] {
            let _ = p.pixel_m(level, plane, l.rows - 1, l.cols - 1);
            for (lat, lon) in PROBES {
                if let Some(h) = p.sample_plane(lat, lon, level, plane) {
                    assert!(h.is_finite(), "sample at ({lat}, {lon}) level {level}: {h}");
                }
            }
        }
        let e = p.extents();
        let regions = [
            Region::Box {
                south_deg: e.south_deg,
                north_deg: e.north_deg,
                west_deg: e.west_deg,
                east_deg: e.east_deg,
            },
            Region::Box {
                south_deg: -10.0,
                north_deg: 10.0,
                west_deg: 170.0,
                east_deg: -170.0,
            },
            Region::Cap {
                lat_deg: 45.0,
                lon_deg: 10.0,
                radius_rad: 0.1,
            },
            Region::Cap {
                lat_deg: 89.0,
                lon_deg: 0.0,
                radius_rad: 2.0,
            },
        ];
        for region in regions {
            if let Some(b) = p.min_max_in(region, level) {
                assert!(b.min_m.is_finite() && b.max_m.is_finite(), "{b:?}");
                if verified {
                    assert!(b.min_m <= b.max_m, "{region:?} level {level}: {b:?}");
                }
            }
        }
    }
    let _ = p.sample(0.0, 0.0, p.level_count());
    format!(
        "ok {} levels{}",
        p.level_count(),
        if verified { "" } else { ", not verified" }
    )
}

/// The relief map detail files are applied to (built once: it is not the input's).
fn relief_map() -> &'static RoughnessMap {
    static MAP: OnceLock<RoughnessMap> = OnceLock::new();
    MAP.get_or_init(|| {
        RoughnessMap::of_bounds(144, globe::geo::EARTH_RADIUS_M, |u, _| {
            (0.0, 2000.0 * u.z.abs())
        })
    })
}

/// The detail parameter file: parse and validate, save and load again (the editor's round
/// trip), and build the detail it describes (octaves, paint on the relief map) and evaluate it.
fn run_detail(input: &Input) -> String {
    let (_, bytes) = &input.files[0];
    // A file that is not UTF-8 is refused when read (`read_to_string`); parse it anyway, with
    // the bad bytes replaced, so that such inputs still reach the parser.
    let text = String::from_utf8_lossy(bytes);
    let params = match DetailParams::parse(&text, Path::new("fuzz.json")) {
        Ok(p) => p,
        Err(e) => return detail_signature(&e),
    };
    let saved = serde_json::to_string_pretty(&params).expect("parameters serialize");
    let loaded = DetailParams::parse(&saved, Path::new("saved.json"))
        .unwrap_or_else(|e| panic!("a saved detail file does not load: {e}\n{saved}"));
    assert!(
        loaded == params,
        "save then load changed the parameters:\n{params:?}\n{loaded:?}"
    );
    let detail = Detail::new(
        params,
        globe::geo::EARTH_RADIUS_M,
        9000.0,
        relief_map().clone(),
    );
    let u = glam::DVec3::new(0.3, 0.4, 0.866).normalize();
    let lambda = detail.lambda_full();
    for v in [
        detail.amplitude_m(u),
        detail.height_m(u, lambda),
        detail.height_m(u, detail.lambda_at_arc_m(10.0)),
        detail.lambda_at_angle(1e-3),
        detail.normalized_bound(lambda),
        detail.normalized_slope_bound(lambda),
    ] {
        assert!(v.is_finite(), "a detail value is {v}");
    }
    let _ = (detail.level_octaves(12, 0.25), detail.check_blend(0.25));
    let _ = (
        detail.anchors(u, detail.octave_count()),
        detail.constants_f32(),
    );
    format!(
        "ok {} octaves {} dabs",
        detail.octave_count(),
        detail.params().relief_paint.len()
    )
}

/// Binary headers in the format's byte order; text where people write it.
fn layout_ehdr(suffix: &str, bytes: &[u8]) -> Shape {
    let text = suffix.ends_with("hdr");
    Shape {
        numbers: if text {
            Numbers::Text
        } else {
            Numbers::BigEndian
        },
        hot: if text { bytes.len() } else { 0 },
        fields: Vec::new(),
    }
}

/// A classic TIFF's first IFD: the entry count, and each entry's type, count and value or
/// offset (kinds 0 to 3), in the file's byte order.
fn layout_tiff(_: &str, b: &[u8]) -> Shape {
    let little = b.starts_with(b"II");
    let u16_at = |at: usize| {
        b.get(at..at + 2).map(|w| {
            let w = [w[0], w[1]];
            if little {
                u16::from_le_bytes(w)
            } else {
                u16::from_be_bytes(w)
            }
        })
    };
    let u32_at = |at: usize| {
        b.get(at..at + 4).map(|w| {
            let w: [u8; 4] = w.try_into().expect("4 bytes");
            if little {
                u32::from_le_bytes(w)
            } else {
                u32::from_be_bytes(w)
            }
        })
    };
    let mut fields = vec![(4, 4, 1)];
    let mut hot = b.len().min(512);
    if let (Some(ifd), true) = (u32_at(4).map(|v| v as usize), b.len() > 8)
        && let Some(n) = u16_at(ifd)
    {
        fields.push((ifd, 2, 0));
        for k in 0..(n as usize).min(64) {
            let e = ifd + 2 + 12 * k;
            if e + 12 > b.len() {
                break;
            }
            fields.extend([(e + 2, 2, 1), (e + 4, 4, 2), (e + 8, 4, 3)]);
            hot = hot.max(e + 12);
        }
    }
    Shape {
        numbers: if little {
            Numbers::LittleEndian
        } else {
            Numbers::BigEndian
        },
        hot: hot.min(b.len()),
        fields,
    }
}

/// Text (the names) up to the `@`, big-endian heights after it.
fn layout_hgt(_: &str, b: &[u8]) -> Shape {
    Shape {
        numbers: Numbers::Text,
        hot: b.iter().position(|&c| c == b'@').unwrap_or(b.len()),
        fields: Vec::new(),
    }
}

fn layout_netcdf(_: &str, bytes: &[u8]) -> Shape {
    let fields = netcdf_fields(bytes);
    Shape {
        numbers: Numbers::BigEndian,
        hot: fields.last().map_or(bytes.len(), |(at, w, _)| at + w),
        fields,
    }
}

/// The numeric fields of a netCDF-3 header (counts, name lengths, dimension lengths and ids,
/// types, `vsize`, `begin`), walked as far as the header is consistent.
fn netcdf_fields(b: &[u8]) -> Vec<Field> {
    // Kinds: 0 numrecs, 1 list tag, 2 list count, 3 name length, 4 dimension length,
    // 5 attribute type, 6 attribute count, 7 ndims, 8 dimension id, 9 variable type,
    // 10 vsize, 11 begin.
    let mut fields = Vec::new();
    let u32_at = |at: usize| {
        b.get(at..at + 4)
            .map(|w| u32::from_be_bytes(w.try_into().expect("4 bytes")) as usize)
    };
    let offset64 = b.get(3) == Some(&2);
    // Each step returns the next offset, or None where the header stops making sense.
    let name = |f: &mut Vec<Field>, at: usize| {
        let n = u32_at(at)?;
        f.push((at, 4, 3));
        Some(at + 4 + n.checked_next_multiple_of(4)?)
    };
    let list = |f: &mut Vec<Field>, at: usize| {
        f.push((at, 4, 1));
        f.push((at + 4, 4, 2));
        Some((at + 8, u32_at(at + 4)?.min(256)))
    };
    let atts = |f: &mut Vec<Field>, at: usize| {
        let (mut at, n) = list(f, at)?;
        for _ in 0..n {
            at = name(f, at)?;
            let ty = u32_at(at)?;
            f.push((at, 4, 5));
            let count = u32_at(at + 4)?;
            f.push((at + 4, 4, 6));
            let size = [0, 1, 1, 2, 4, 4, 8].get(ty).copied().unwrap_or(1);
            at += 8 + count.checked_mul(size)?.checked_next_multiple_of(4)?;
        }
        Some(at)
    };
    let walk = |f: &mut Vec<Field>| -> Option<()> {
        f.push((4, 4, 0));
        let (mut at, ndims) = list(f, 8)?;
        for _ in 0..ndims {
            at = name(f, at)?;
            f.push((at, 4, 4));
            at += 4;
        }
        at = atts(f, at)?;
        let (mut at, nvars) = list(f, at)?;
        for _ in 0..nvars {
            at = name(f, at)?;
            let nd = u32_at(at)?.min(64);
            f.push((at, 4, 7));
            for k in 0..nd {
                f.push((at + 4 + 4 * k, 4, 8));
            }
            at = atts(f, at + 4 + 4 * nd)?;
            f.push((at, 4, 9));
            f.push((at + 4, 4, 10));
            f.push((at + 8, if offset64 { 8 } else { 4 }, 11));
            at += if offset64 { 16 } else { 12 };
        }
        Some(())
    };
    let _ = walk(&mut fields);
    fields.retain(|&(at, w, _)| at + w <= b.len());
    fields
}

fn layout_pyramid(_: &str, bytes: &[u8]) -> Shape {
    let u32_at = |at: usize| {
        bytes.get(at..at + 4).map_or(0, |w| {
            u32::from_le_bytes(w.try_into().expect("4 bytes")) as usize
        })
    };
    let header_len = u32_at(12).clamp(136, bytes.len().max(136));
    // The fixed header (each field its own kind: its offset), the level table (a kind per
    // column) and the tile index (offsets, lengths): module docs of `dem::pyramid`.
    let mut fields: Vec<Field> = (8..32).step_by(4).map(|at| (at, 4, at as u8)).collect();
    fields.extend((32..128).step_by(8).map(|at| (at, 8, at as u8)));
    fields.push((128, 4, 128));
    let table = 136 + u32_at(128).min(4096).next_multiple_of(8);
    let levels = u32_at(20).min(64);
    for l in 0..levels {
        let at = table + 64 * l;
        fields.extend((0..16).step_by(4).map(|o| (at + o, 4, 200 + o as u8)));
        fields.extend((16..56).step_by(8).map(|o| (at + o, 8, 200 + o as u8)));
    }
    let mut at = table + 64 * levels;
    while at + 16 <= header_len.saturating_sub(4) {
        fields.extend([(at, 8, 100), (at + 8, 4, 101)]);
        at += 16;
    }
    fields.retain(|&(at, w, _)| at + w <= bytes.len());
    Shape {
        numbers: Numbers::LittleEndian,
        hot: header_len,
        fields,
    }
}

fn layout_detail(_: &str, bytes: &[u8]) -> Shape {
    Shape {
        numbers: Numbers::Text,
        hot: bytes.len(),
        fields: Vec::new(),
    }
}

/// The pyramid's header CRC (usually) and tile CRCs (often) recomputed after mutation, so that
/// mutations reach the checks behind the checksums.
fn fix_pyramid_crcs(rng: &mut Rng, input: &mut Input) {
    let b = &mut input.files[0].1;
    if b.len() < 16 || rng.one_in(8) {
        return;
    }
    let header_len = u32::from_le_bytes(b[12..16].try_into().expect("4 bytes")) as usize;
    if !(140..=b.len()).contains(&header_len) {
        return;
    }
    if rng.one_in(2) {
        // Tile CRCs: every index entry whose payload lies in the file.
        let levels = u32::from_le_bytes(b[20..24].try_into().expect("4 bytes")) as usize;
        let desc = b.get(128..132).map_or(0, |d| {
            u32::from_le_bytes(d.try_into().expect("4 bytes")) as usize
        });
        let index_at = 136 + desc.next_multiple_of(8) + 64 * levels.min(64);
        let mut at = index_at;
        while at + 16 <= header_len - 4 {
            let offset = u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes")) as usize;
            let len = u32::from_le_bytes(b[at + 8..at + 12].try_into().expect("4 bytes")) as usize;
            if let Some(payload) = offset.checked_add(len).and_then(|end| b.get(offset..end)) {
                let crc = crc32fast::hash(payload);
                b[at + 12..at + 16].copy_from_slice(&crc.to_le_bytes());
            }
            at += 16;
        }
    }
    let crc = crc32fast::hash(&b[..header_len - 4]);
    b[header_len - 4..header_len].copy_from_slice(&crc.to_le_bytes());
}

/// Keys and values of `.HDR` files, whole lines among them.
const EHDR_WORDS: &[&str] = &[
    "BYTEORDER",
    "LAYOUT",
    "NROWS",
    "NCOLS",
    "NBANDS",
    "NBITS",
    "PIXELTYPE",
    "BANDROWBYTES",
    "TOTALROWBYTES",
    "BANDGAPBYTES",
    "SKIPBYTES",
    "NODATA",
    "NODATA_VALUE",
    "ULXMAP",
    "ULYMAP",
    "XDIM",
    "YDIM",
    "XLLCORNER",
    "YLLCORNER",
    "XLLCENTER",
    "YLLCENTER",
    "CELLSIZE",
    "BIL",
    "BIP",
    "BSQ",
    "I",
    "M",
    "LSBFIRST",
    "MSBFIRST",
    "SIGNEDINT",
    "UNSIGNEDINT",
    "FLOAT",
    "nan",
    "8",
    "16",
    "32",
    "\nLAYOUT BIP\n",
    "\nLAYOUT BSQ\n",
    "\nNBANDS 3\n",
    "\nSKIPBYTES 4\n",
    "\nBANDGAPBYTES 2\n",
    "\nPIXELTYPE FLOAT\n",
    "\nNODATA nan\n",
    "\nBYTEORDER I\n",
    "\nXLLCORNER 10\n",
    "\nYLLCENTER 45\n",
    "\u{feff}",
];

/// Names and text the CF adaptor reads.
const NETCDF_WORDS: &[&str] = &[
    "lat",
    "lon",
    "latitude",
    "longitude",
    "units",
    "degrees_north",
    "degrees_east",
    "axis",
    "standard_name",
    "scale_factor",
    "add_offset",
    "_FillValue",
    "missing_value",
    "valid_range",
    "valid_min",
    "valid_max",
    "feet",
    "km",
    "CDF\x02",
    "CDF\x01",
];

/// Fields and JSON syntax of detail files.
const DETAIL_WORDS: &[&str] = &[
    "seed",
    "hurst",
    "lacunarity",
    "floor_m",
    "octaves_below_data",
    "amplitude_min_m",
    "roughness_gain",
    "amplitude_max_m",
    "height_roughness",
    "geometry_cut",
    "warp",
    "c1",
    "c2",
    "c3",
    "lever_cells",
    "relief_paint",
    "lat_deg",
    "lon_deg",
    "radius_deg",
    "factor",
    "null",
    "true",
    "[]",
    "{}",
    "\"relief_paint\": [{\"lat_deg\": 90, \"lon_deg\": 0, \"radius_deg\": 45, \"factor\": 10}],",
    "{\"lat_deg\": -89.9, \"lon_deg\": 360, \"radius_deg\": 0.1, \"factor\": 0},",
    "\"seed\": 4294967295,",
    "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[",
];

const EHDR: Target = Target {
    name: "ehdr",
    ci_iters: 40_000,
    run: run_ehdr,
    layout: layout_ehdr,
    fix_up: None,
    dictionary: EHDR_WORDS,
};

const NETCDF: Target = Target {
    name: "netcdf",
    ci_iters: 60_000,
    run: run_netcdf,
    layout: layout_netcdf,
    fix_up: None,
    dictionary: NETCDF_WORDS,
};

const PYRAMID: Target = Target {
    name: "pyramid",
    ci_iters: 100_000,
    run: run_pyramid,
    layout: layout_pyramid,
    fix_up: Some(fix_pyramid_crcs),
    dictionary: &["GLOBEPYR"],
};

const DETAIL: Target = Target {
    name: "detail",
    ci_iters: 100_000,
    run: run_detail,
    layout: layout_detail,
    fix_up: None,
    dictionary: DETAIL_WORDS,
};

const GEOTIFF: Target = Target {
    name: "geotiff",
    ci_iters: 40_000,
    run: run_geotiff,
    layout: layout_tiff,
    fix_up: None,
    dictionary: &[
        "II*\0", "MM\0*", "II+\0", "EPSG", "WGS 84|", "-32768", "nan",
    ],
};

const HGT: Target = Target {
    name: "hgt",
    // An accepted input builds and reads a whole 1201² tile, alone and as a mosaic (about
    // 16 ms here): 400 take 4 to 7 s on the 2-core VM.
    ci_iters: 400,
    run: run_hgt,
    layout: layout_hgt,
    fix_up: None,
    dictionary: &[
        "N", "S", "E", "W", "n00e000", "S90W180", "N89E180", ".hgt", "\n",
    ],
};

const TARGETS: [&Target; 6] = [&EHDR, &NETCDF, &PYRAMID, &DETAIL, &GEOTIFF, &HGT];

#[test]
fn fuzz_ehdr() {
    fuzz_target(&EHDR);
}

#[test]
fn fuzz_netcdf() {
    fuzz_target(&NETCDF);
}

#[test]
fn fuzz_pyramid() {
    fuzz_target(&PYRAMID);
}

#[test]
fn fuzz_detail() {
    fuzz_target(&DETAIL);
}

#[test]
fn fuzz_geotiff() {
    fuzz_target(&GEOTIFF);
}

#[test]
fn fuzz_hgt() {
    fuzz_target(&HGT);
}

/// Every seed (the corpus less the `crash-*` inputs) is accepted by its parser: the mutations
/// start from valid files.
#[test]
fn seeds_are_valid() {
    for target in TARGETS {
        for (stem, input) in corpus(target.name) {
            if stem.starts_with("crash-") {
                continue;
            }
            let signature = (target.run)(&input);
            assert!(
                signature
                    .split(" | ")
                    .all(|s| s.starts_with("ok") || s.starts_with("mosaic ok")),
                "{}/{stem}: {signature}",
                target.name
            );
        }
    }
}

/// Every corpus input, as it is, runs clean (the seeds, and every input that once failed).
#[test]
fn corpus_runs_clean() {
    quiet_panics();
    let mut failures = Vec::new();
    for target in TARGETS {
        for (stem, input) in corpus(target.name) {
            let exec = execute(target, &Arc::new(input));
            if let Some(f) = exec.failure {
                failures.push(format!("{}/{stem}: {f}", target.name));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// Regression tests: every input the fuzzer found failing, and what it must give now
// ---------------------------------------------------------------------------------------------

/// A detail file's numbers are read exactly, so what the editor saves loads back bit for bit.
/// Found by `fuzz_detail`: serde_json's default float parser read
/// `0.000000000000000000000000000001` as 9.999999999999999e-31 (one ulp off), so save then
/// load changed `warp.lever_cells`; fixed with serde_json's `float_roundtrip` feature.
#[test]
fn regression_detail_floats_read_exactly() {
    let input = corpus_input("detail", "crash-float-roundtrip");
    let text = std::str::from_utf8(&input.files[0].1).expect("UTF-8");
    let path = Path::new("crash-float-roundtrip.json");
    let params = DetailParams::parse(text, path).expect("a valid detail file");
    assert_eq!(params.warp.lever_cells, 1e-30);
    let saved = serde_json::to_string_pretty(&params).expect("serialises");
    let loaded = DetailParams::parse(&saved, path).expect("loads");
    assert_eq!(loaded, params);
    assert_eq!(loaded.warp.lever_cells.to_bits(), 1e-30f64.to_bits());
}

/// Two tiles far apart on a very fine lattice are refused as a mosaic, before anything is sized
/// by its bounding grid. Found by `fuzz_ehdr`: two 6 × 8 GTOPO30-style tiles with `XDIM 1e-10`,
/// 0.5° apart, made a mosaic 5·10⁹ columns wide, whose first row (as the importer reads it)
/// asked for 20 GB; the hard cap refused it and the process aborted.
#[test]
fn regression_sparse_mosaic_is_refused() {
    let input = corpus_input("ehdr", "crash-mosaic-sparse");
    let file = |suffix: &str| {
        let (_, b) = input.files.iter().find(|(s, _)| s == suffix).expect("file");
        b.clone()
    };
    let rasters: Vec<EhdrRaster> = ["1", "2"]
        .iter()
        .map(|i| {
            let hdr = format!("crash-mosaic-sparse.{i}.hdr");
            let data = format!("crash-mosaic-sparse.{i}.dem");
            EhdrRaster::from_bytes(
                &file(&format!("{i}.hdr")),
                hdr,
                file(&format!("{i}.dem")),
                data,
            )
            .expect("each tile is a valid raster")
        })
        .collect();
    let e = EhdrMosaic::from_rasters(rasters, "sparse").expect_err("refused");
    let message = e.to_string();
    assert!(matches!(e, DemError::Data { .. }), "{e:?}");
    for needle in [
        "sparse: the tiles hold 96 pixels",
        "bounding grid of 5000000006 × 8",
        "XDIM 0.0000000001",
        "crash-mosaic-sparse.1.hdr is the westernmost",
        "crash-mosaic-sparse.2.hdr the easternmost",
        "at least 1/64",
    ] {
        assert!(message.contains(needle), "{needle:?} not in {message}");
    }
}

/// A tile whose CRC matches but whose min plane lies above its max plane is refused where
/// codes are vouched for: by `verify` and by `tile_verified` (the streamer's read). Found by
/// `fuzz_pyramid` (with the tile CRCs recomputed after mutating): `min_max_in` gave
/// min 42 m > max 0 m at level 2.
#[test]
fn regression_pyramid_tile_min_above_max() {
    let input = corpus_input("pyramid", "crash-min-above-max");
    let p = Pyramid::from_bytes(input.files[0].1.clone(), "crash-min-above-max.globepyr")
        .expect("the header is valid");
    let bad = |e: DemError| match e {
        DemError::TileContent {
            level,
            tx,
            ty,
            x,
            y,
            message,
            ..
        } => {
            assert_eq!((level, tx, ty, x, y), (2, 0, 0, 0, 0));
            assert!(message.contains("expected min ≤ avg ≤ max"), "{message}");
        }
        other => panic!("{other:?}"),
    };
    bad(p.verify().expect_err("verify refuses it"));
    bad(p
        .tile_verified(2, 0, 0)
        .expect_err("the streamer's read refuses it"));
    assert!(p.tile_verified(0, 0, 0).is_ok(), "the other tiles are fine");
}

/// A header whose height range is not a range of heights the codes can hold is refused at
/// open (a reader takes it as the terrain's height range). Found by `fuzz_pyramid`: a header
/// CRC-valid file with the lowest min NaN opened, and `info()` said NaN … 2041 m.
#[test]
fn regression_pyramid_height_range_nan() {
    let input = corpus_input("pyramid", "crash-height-range-nan");
    let e = Pyramid::from_bytes(input.files[0].1.clone(), "crash-height-range-nan.globepyr")
        .expect_err("refused");
    match &e {
        DemError::Header { field, message, .. } => {
            assert_eq!(field, "height range");
            assert!(message.contains("lowest min NaN m"), "{message}");
            assert!(
                message.contains("within the encoding's -32767 … 32767 m"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
}

/// Record variables whose slabs add up past 2^64 bytes are a header error naming the variable.
/// Found by `fuzz_netcdf` (the `lat` and `lon` lengths of `record-series.nc` both set to
/// 0x7d000000): the record size was summed unchecked, which panicked on overflow in debug
/// builds and wrapped in release.
#[test]
fn regression_netcdf_record_size_overflow() {
    let input = corpus_input("netcdf", "crash-record-size-overflow");
    let e = NetcdfFile::from_bytes(input.files[0].1.clone(), "crash-record-size-overflow.nc")
        .expect_err("refused");
    match &e {
        DemError::Header { field, message, .. } => {
            assert_eq!(field, r#"var_list["error"]"#);
            assert!(message.starts_with("record size overflows"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}

/// An infinite extent is not "close" to the level-0 grid's footprint. Found by `fuzz_pyramid`:
/// a header CRC-valid file whose western extent was +inf opened (the tolerance, relative to
/// the larger value, was infinite too) and sampled NaN everywhere.
/// A GeoKeyDirectory stored as LONG8 whose key count times 4 overflowed (a panic in debug
/// builds); found by `fuzz_geotiff` once a file without a CRS was accepted. Now a header error
/// on the directory.
#[test]
fn regression_geotiff_geokey_count_overflow() {
    let input = corpus_input("geotiff", "crash-geokey-count-overflow");
    let refused: Vec<String> = input
        .files
        .iter()
        .filter_map(|(suffix, bytes)| GeoTiffRaster::from_bytes(bytes.clone(), suffix).err())
        .filter(|e| matches!(e, DemError::Header { field, .. } if field == "GeoKeyDirectory"))
        .map(|e| e.to_string())
        .collect();
    assert!(
        refused.iter().any(|m| m.contains("keys; expected")),
        "{refused:?}"
    );
    assert!(run_geotiff(&input).contains("header GeoKeyDirectory"));
}

#[test]
fn regression_pyramid_infinite_extent() {
    let input = corpus_input("pyramid", "crash-extent-infinite");
    let e = Pyramid::from_bytes(input.files[0].1.clone(), "crash-extent-infinite.globepyr")
        .expect_err("refused");
    match &e {
        DemError::Header { field, message, .. } => {
            assert_eq!(field, "extents");
            assert!(message.contains("west_deg: inf"), "{message}");
            assert!(
                message.contains("do not match the level-0 grid's footprint"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// The seeds (run by hand: `cargo test --test fuzz write_seeds -- --ignored`)
// ---------------------------------------------------------------------------------------------

const ETOPO5: &str = "/usr/share/ferret-vis/data/etopo5.cdf";
/// The seeds' window of ETOPO5: the Alps around Lake Garda, 10°–11° E, 46°–45.42° N (GDAL's
/// `-srcwin`: first column from 0° E, first row from 90° N, columns, rows of 5′ nodes).
const WINDOW: (usize, usize, usize, usize) = (120, 528, 12, 8);
/// ETOPO5's rows (stored south to north).
const ETOPO5_ROWS: usize = 2161;

fn write_seed(target: &str, name: &str, bytes: &[u8]) {
    let dir = corpus_dir(target);
    std::fs::create_dir_all(&dir).expect("corpus folder");
    std::fs::write(dir.join(name), bytes).expect("seed written");
}

fn be32(v: u32) -> [u8; 4] {
    v.to_be_bytes()
}

/// Replaces the one occurrence of `old` in `b` (after `from`) with `new` (same length).
fn patch(b: &mut [u8], from: usize, old: &[u8], new: &[u8]) {
    let at = b[from..]
        .windows(old.len())
        .position(|w| w == old)
        .unwrap_or_else(|| panic!("{old:02x?} not found"))
        + from;
    b[at..at + new.len()].copy_from_slice(new);
}

/// ETOPO5's own header with its dimensions shrunk to the window, followed by the window's
/// coordinates and heights copied from the file (a real header, a few hundred bytes of data).
fn etopo5_window() -> Vec<u8> {
    let (x0, y_north, nx, ny) = WINDOW;
    let y0 = ETOPO5_ROWS - y_north - ny; // the window's southernmost row in the file
    let nc = NetcdfFile::open(ETOPO5).expect("ETOPO5 (apt-get install ferret-datasets)");
    let file = std::fs::read(ETOPO5).expect("ETOPO5");
    let var = |n: &str| nc.variable(n).expect("ETOPO5 variable").clone();
    let (vx, vy, vz) = (var("ETOPO05_X"), var("ETOPO05_Y"), var("ROSE"));
    let header_end = vx.begin as usize;
    let mut out = file[..header_end].to_vec();
    // dim_list: each dimension's length follows its (padded) name.
    for (name, n) in [(&b"ETOPO05_X"[..], nx), (&b"ETOPO05_Y"[..], ny)] {
        let len = nc
            .dimensions()
            .iter()
            .find(|d| d.name.as_bytes() == name)
            .expect("dimension")
            .len;
        let mut old = name.to_vec();
        old.resize(name.len().next_multiple_of(4), 0);
        old.extend_from_slice(&be32(len as u32));
        let mut new = old.clone();
        let l = new.len();
        new[l - 4..].copy_from_slice(&be32(n as u32));
        patch(&mut out, 0, &old, &new);
    }
    // var_list: each variable's (vsize, begin).
    let sizes = [nx * 8, ny * 8, nx * ny * 4];
    let mut begin = header_end;
    for (v, size) in [&vx, &vy, &vz].into_iter().zip(sizes) {
        let old = [be32(v.vsize as u32), be32(v.begin as u32)].concat();
        let new = [be32(size as u32), be32(begin as u32)].concat();
        patch(&mut out, 0, &old, &new);
        begin += size;
    }
    out.extend_from_slice(&file[vx.begin as usize + 8 * x0..][..8 * nx]);
    out.extend_from_slice(&file[vy.begin as usize + 8 * y0..][..8 * ny]);
    for r in y0..y0 + ny {
        let row = vz.begin as usize + 4 * (r * 4320 + x0);
        out.extend_from_slice(&file[row..row + 4 * nx]);
    }
    out
}

/// One variable for [`cdf1`]: dimension ids, nc_type, attributes (text, or one float) and its
/// data (big-endian; for a record variable, every record's slab in turn).
struct NcVar {
    name: &'static str,
    dims: Vec<u32>,
    nc_type: u32,
    atts: Vec<(&'static str, NcAtt)>,
    data: Vec<u8>,
}

enum NcAtt {
    Text(&'static str),
    Float(f32),
}

/// A small CDF-1 writer (the netCDF classic format specification): `dims` (length 0: the
/// record dimension, which must be 0 if present), fixed variables first, then `numrecs` records
/// of every record variable's padded slab.
fn cdf1(numrecs: u32, dims: &[(&str, u32)], vars: &[NcVar]) -> Vec<u8> {
    fn name(b: &mut Vec<u8>, s: &str) {
        b.extend_from_slice(&be32(s.len() as u32));
        b.extend_from_slice(s.as_bytes());
        b.resize(b.len().next_multiple_of(4), 0);
    }
    let is_record = |v: &NcVar| v.dims.first().is_some_and(|&d| dims[d as usize].1 == 0);
    let size = |v: &NcVar| [0, 1, 1, 2, 4, 4, 8][v.nc_type as usize];
    // vsize is a 32-bit field: sizes beyond it are stored wrapped (what the spec allows for
    // the last variable).
    let slab = |v: &NcVar| {
        let n: u64 = v
            .dims
            .iter()
            .skip(is_record(v) as usize)
            .map(|&d| dims[d as usize].1 as u64)
            .product();
        (n * size(v) as u64).next_multiple_of(4) as u32
    };
    let mut b = b"CDF\x01".to_vec();
    b.extend_from_slice(&be32(numrecs));
    b.extend_from_slice(&[be32(0x0A), be32(dims.len() as u32)].concat());
    for (n, len) in dims {
        name(&mut b, n);
        b.extend_from_slice(&be32(*len));
    }
    b.extend_from_slice(&[be32(0), be32(0)].concat()); // no global attributes
    b.extend_from_slice(&[be32(0x0B), be32(vars.len() as u32)].concat());
    let mut begins = Vec::new();
    for v in vars {
        name(&mut b, v.name);
        b.extend_from_slice(&be32(v.dims.len() as u32));
        for d in &v.dims {
            b.extend_from_slice(&be32(*d));
        }
        b.extend_from_slice(&[be32(0x0C), be32(v.atts.len() as u32)].concat());
        for (n, value) in &v.atts {
            name(&mut b, n);
            match value {
                NcAtt::Text(t) => {
                    b.extend_from_slice(&[be32(2), be32(t.len() as u32)].concat());
                    b.extend_from_slice(t.as_bytes());
                    b.resize(b.len().next_multiple_of(4), 0);
                }
                NcAtt::Float(x) => {
                    b.extend_from_slice(&[be32(5), be32(1)].concat());
                    b.extend_from_slice(&x.to_be_bytes());
                }
            }
        }
        b.extend_from_slice(&[be32(v.nc_type), be32(slab(v))].concat());
        begins.push(b.len());
        b.extend_from_slice(&be32(0)); // begin, set below
    }
    let record_size: u32 = vars.iter().filter(|v| is_record(v)).map(slab).sum();
    let mut at = b.len() as u32;
    for (v, &begin) in vars.iter().zip(&begins).filter(|(v, _)| !is_record(v)) {
        b[begin..begin + 4].copy_from_slice(&be32(at));
        at += slab(v);
    }
    let mut in_record = 0;
    for (v, &begin) in vars.iter().zip(&begins).filter(|(v, _)| is_record(v)) {
        b[begin..begin + 4].copy_from_slice(&be32(at + in_record));
        in_record += slab(v);
    }
    for v in vars.iter().filter(|v| !is_record(v)) {
        b.extend_from_slice(&v.data);
        b.resize(b.len().next_multiple_of(4), 0);
    }
    for r in 0..numrecs as usize {
        for v in vars.iter().filter(|v| is_record(v)) {
            let n = (v
                .dims
                .iter()
                .skip(1)
                .map(|&d| dims[d as usize].1)
                .product::<u32>()
                * size(v)) as usize;
            b.extend_from_slice(&v.data[r * n..(r + 1) * n]);
            b.resize(b.len().next_multiple_of(4), 0);
        }
    }
    debug_assert_eq!(b.len() as u32, at + numrecs * record_size);
    b
}

fn doubles(v: impl IntoIterator<Item = f64>) -> Vec<u8> {
    v.into_iter().flat_map(f64::to_be_bytes).collect()
}

/// Two netCDF seeds around the window's heights (rows north to south): latitude as the record
/// dimension (the coordinate and the heights both record variables, so records interleave;
/// short heights packed with `scale_factor`, in feet), and fixed heights with two 3-D record
/// variables beside them (a time series, as CF files often carry).
fn record_files(heights: &[f32], nx: usize, ny: usize) -> [Vec<u8>; 2] {
    let lats = doubles((0..ny).map(|r| 46.0 - r as f64 / 12.0));
    let lons = doubles((0..nx).map(|c| 10.0 + c as f64 / 12.0));
    let degrees = |axis| vec![("units", NcAtt::Text(axis))];
    let feet: Vec<u8> = heights
        .iter()
        .flat_map(|h| (((h / 0.3048) / 0.5).round() as i16).to_be_bytes())
        .collect();
    let record_lat = cdf1(
        ny as u32,
        &[("lat", 0), ("lon", nx as u32)],
        &[
            NcVar {
                name: "lat",
                dims: vec![0],
                nc_type: 6,
                atts: degrees("degrees_north"),
                data: lats.clone(),
            },
            NcVar {
                name: "lon",
                dims: vec![1],
                nc_type: 6,
                atts: degrees("degrees_east"),
                data: lons.clone(),
            },
            NcVar {
                name: "elev",
                dims: vec![0, 1],
                nc_type: 3,
                atts: vec![
                    ("units", NcAtt::Text("feet")),
                    ("scale_factor", NcAtt::Float(0.5)),
                ],
                data: feet,
            },
        ],
    );
    let metres: Vec<u8> = heights
        .iter()
        .flat_map(|h| (*h as i16).to_be_bytes())
        .collect();
    let ints = |k: i32| -> Vec<u8> {
        heights
            .iter()
            .flat_map(|h| (*h as i32 / k).to_be_bytes())
            .collect()
    };
    let series = cdf1(
        1,
        &[("time", 0), ("lat", ny as u32), ("lon", nx as u32)],
        &[
            NcVar {
                name: "lat",
                dims: vec![1],
                nc_type: 6,
                atts: degrees("degrees_north"),
                data: lats,
            },
            NcVar {
                name: "lon",
                dims: vec![2],
                nc_type: 6,
                atts: degrees("degrees_east"),
                data: lons,
            },
            NcVar {
                name: "elev",
                dims: vec![1, 2],
                nc_type: 3,
                atts: vec![("units", NcAtt::Text("m"))],
                data: metres,
            },
            NcVar {
                name: "change",
                dims: vec![0, 1, 2],
                nc_type: 4,
                atts: vec![],
                data: ints(100),
            },
            NcVar {
                name: "error",
                dims: vec![0, 1, 2],
                nc_type: 4,
                atts: vec![],
                data: ints(1000),
            },
        ],
    );
    [record_lat, series]
}

/// Runs a command, panicking with its output when it fails.
fn command(program: &str, args: &[&str]) {
    let out = std::process::Command::new(program)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{program}: {e}"));
    assert!(
        out.status.success(),
        "{program} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A global grid from ETOPO5, every `step`-th node.
struct Decimated {
    raster: NetcdfRaster,
    step: usize,
}

impl RasterSource for Decimated {
    fn grid(&self) -> globe::dem::GeoGrid {
        let g = self.raster.grid();
        globe::dem::GeoGrid {
            cols: g.cols / self.step,
            rows: g.rows.div_ceil(self.step),
            dlon_deg: g.dlon_deg * self.step as f64,
            dlat_deg: g.dlat_deg * self.step as f64,
            ..g
        }
    }

    fn read_row(&self, row: usize, out: &mut [f32]) -> Result<(), DemError> {
        let mut full = vec![0f32; self.raster.grid().cols];
        self.raster.read_row(row * self.step, &mut full)?;
        for (c, o) in out.iter_mut().enumerate() {
            *o = full[c * self.step];
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!("ETOPO5 every {}th node", self.step)
    }
}

/// Writes the seeds of every target from real files: ETOPO5 (Debian's `ferret-datasets`),
/// GDAL's EHdr and netCDF writers (`gdal-bin`), the project's own EHdr and pyramid writers and
/// the shipped detail presets. Crash inputs in the corpus are left alone.
#[test]
#[ignore = "writes tests/fuzz_corpus; needs ETOPO5 and GDAL"]
fn write_seeds() {
    let tmp = tempfile::tempdir().expect("temporary folder");
    let t = |name: &str| tmp.path().join(name).to_string_lossy().into_owned();
    let (x0, y0, nx, ny) = WINDOW;
    let srcwin = [x0, y0, nx, ny].map(|v| v.to_string());
    let srcwin: Vec<&str> = srcwin.iter().map(String::as_str).collect();

    // netCDF: ETOPO5's header, GDAL's CDF-1 and CDF-2, and a record-dimension file.
    let etopo = etopo5_window();
    write_seed("netcdf", "etopo5-window.cdf", &etopo);
    for (format, name) in [("NC", "gdal-cdf1.nc"), ("NC2", "gdal-cdf2.nc")] {
        let format = format!("FORMAT={format}");
        let out = t(name);
        let args = [
            &["-q", "-of", "netCDF", "-co"][..],
            &[&format, "-co", "WRITE_GDAL_TAGS=NO", "-srcwin"],
            &srcwin,
            &[ETOPO5, &out],
        ]
        .concat();
        command("gdal_translate", &args);
        write_seed(
            "netcdf",
            name,
            &std::fs::read(t(name)).expect("GDAL's netCDF"),
        );
    }
    std::fs::write(t("window.cdf"), &etopo).expect("window");
    let window = NetcdfRaster::open(t("window.cdf"), None).expect("the window opens");
    let mut heights = vec![0f32; nx * ny];
    for (r, row) in heights.chunks_mut(nx).enumerate() {
        window.read_row(r, row).expect("window row");
    }
    let [record_lat, series] = record_files(&heights, nx, ny);
    write_seed("netcdf", "record-lat.nc", &record_lat);
    write_seed("netcdf", "record-series.nc", &series);

    // EHdr: GDAL's writer (several sample types, two bands), ESRI GridFloat with corners, and
    // two GTOPO30-style tiles from our writer (a mosaic).
    for (ty, extra, name) in [
        ("Int16", &[][..], "gdal-int16"),
        ("Float32", &[][..], "gdal-float32"),
        (
            "Byte",
            &["-scale", "0", "4000", "0", "255"][..],
            "gdal-byte",
        ),
        ("UInt32", &[][..], "gdal-uint32"),
        ("Int16", &["-b", "1", "-b", "1"][..], "gdal-two-bands"),
    ] {
        let out = t(&format!("{name}.bil"));
        let args = [
            &["-q", "-of", "EHdr", "-ot", ty][..],
            extra,
            &["-srcwin"],
            &srcwin,
            &[ETOPO5, &out],
        ]
        .concat();
        command("gdal_translate", &args);
        for ext in ["hdr", "bil"] {
            let bytes = std::fs::read(t(&format!("{name}.{ext}"))).expect("GDAL's EHdr");
            write_seed("ehdr", &format!("{name}.{ext}"), &bytes);
        }
    }
    let float = std::fs::read(t("gdal-float32.bil")).expect("float data");
    let g = window.grid();
    let corner = format!(
        "ncols {nx}\nnrows {ny}\nxllcorner {}\nyllcorner {}\ncellsize {}\nNODATA_value -9999\n\
         byteorder LSBFIRST\n",
        g.lon0_deg - g.dlon_deg / 2.0,
        g.lat0_deg - (ny as f64 - 0.5) * g.dlat_deg,
        g.dlon_deg
    );
    write_seed("ehdr", "gridfloat-corner.hdr", corner.as_bytes());
    write_seed("ehdr", "gridfloat-corner.flt", &float);
    let half = nx / 2;
    for (i, c0) in [(1, 0), (2, half)] {
        let grid = globe::dem::GeoGrid {
            cols: half,
            lon0_deg: g.lon0_deg + c0 as f64 * g.dlon_deg,
            ..g
        };
        let rows: Vec<Vec<f32>> = heights
            .chunks(nx)
            .map(|r| r[c0..c0 + half].to_vec())
            .collect();
        let stem = tmp.path().join(format!("tile{i}"));
        let options = globe::dem::ehdr::EhdrWriteOptions::gtopo30();
        globe::dem::ehdr::write_ehdr(&stem, &grid, &options, rows).expect("tile written");
        for (ext, file) in [("hdr", "HDR"), ("dem", "DEM")] {
            let bytes = std::fs::read(t(&format!("tile{i}.{file}"))).expect("tile");
            write_seed("ehdr", &format!("gtopo-pair.{i}.{ext}"), &bytes);
        }
    }

    // Pyramids from the project's builder: the regional window, and a global grid that wraps.
    let sources: [(&str, Box<dyn RasterSource>); 2] = [
        ("window", Box::new(window)),
        (
            "global",
            Box::new(Decimated {
                raster: NetcdfRaster::open(ETOPO5, None).expect("ETOPO5"),
                step: 270,
            }),
        ),
    ];
    for (name, source) in sources {
        let out = t(&format!("{name}.globepyr"));
        globe::dem::PyramidBuilder::new()
            .tile_size(4)
            .build(&*source, &out)
            .expect("pyramid built");
        let bytes = std::fs::read(&out).expect("pyramid");
        write_seed("pyramid", &format!("{name}.globepyr"), &bytes);
    }

    // Detail files: the shipped presets, and one saved by the editor's format with paint.
    for preset in globe::procedural::presets::PRESETS {
        let name = Path::new(preset.file).file_name().expect("name");
        write_seed("detail", &name.to_string_lossy(), preset.json.as_bytes());
    }
    let mut painted = DetailParams {
        seed: 7,
        hurst: 0.7,
        floor_m: 0.05,
        ..DetailParams::default()
    };
    painted.relief_paint = vec![
        globe::procedural::ReliefDab {
            lat_deg: 45.65,
            lon_deg: 10.65,
            radius_deg: 2.0,
            factor: 3.0,
        },
        globe::procedural::ReliefDab {
            lat_deg: 89.0,
            lon_deg: -170.0,
            radius_deg: 20.0,
            factor: 0.0,
        },
    ];
    painted
        .save(&tmp.path().join("painted.json"))
        .expect("saved");
    let bytes = std::fs::read(t("painted.json")).expect("painted");
    write_seed("detail", "painted.json", &bytes);

    write_raster_seeds();
}

/// The GeoTIFF and SRTM seeds alone: `cargo test --test fuzz write_raster_seeds -- --ignored`.
#[test]
#[ignore = "writes tests/fuzz_corpus/{geotiff,hgt}; needs ETOPO5 and GDAL"]
fn write_raster_seeds_only() {
    write_raster_seeds();
}

/// GeoTIFFs GDAL writes from the seeds' ETOPO5 window (strips and tiles, Deflate/LZW/none, the
/// three sample types, both byte orders, PixelIsPoint with GDAL_NODATA, a COG, and a pair of
/// halves for the mosaic); SRTM inputs from the start of a tile GDAL's SRTMHGT driver wrote.
fn write_raster_seeds() {
    let tmp = tempfile::tempdir().expect("temporary folder");
    let t = |name: &str| tmp.path().join(name).to_string_lossy().into_owned();
    let (x0, y0, nx, ny) = WINDOW;
    let win = |x: usize, w: usize| [x, y0, w, ny].map(|v| v.to_string());
    let variants: [(&str, &[&str], [String; 4]); 8] = [
        (
            "gdal-int16-deflate",
            &[
                "-ot",
                "Int16",
                "-co",
                "COMPRESS=DEFLATE",
                "-co",
                "BLOCKYSIZE=3",
            ],
            win(x0, nx),
        ),
        (
            "gdal-uint16-lzw",
            &[
                "-ot",
                "UInt16",
                "-co",
                "COMPRESS=LZW",
                "-co",
                "PREDICTOR=2",
                "-co",
                "BLOCKYSIZE=4",
            ],
            win(x0, nx),
        ),
        (
            "gdal-float32-tiled",
            &[
                "-ot",
                "Float32",
                "-co",
                "TILED=YES",
                "-co",
                "BLOCKXSIZE=16",
                "-co",
                "BLOCKYSIZE=16",
                "-co",
                "COMPRESS=DEFLATE",
                "-co",
                "PREDICTOR=3",
            ],
            win(x0, nx),
        ),
        (
            "gdal-int16-big-endian",
            &["-ot", "Int16", "-co", "ENDIANNESS=BIG"],
            win(x0, nx),
        ),
        (
            "gdal-point-nodata",
            &[
                "-ot",
                "Int16",
                "-mo",
                "AREA_OR_POINT=Point",
                "-a_nodata",
                "-32768",
            ],
            win(x0, nx),
        ),
        (
            "gdal-cog",
            &["-of", "COG", "-ot", "Int16", "-co", "COMPRESS=LZW"],
            win(x0, nx),
        ),
        (
            "gdal-pair.1",
            &["-ot", "Int16", "-co", "COMPRESS=DEFLATE"],
            win(x0, nx / 2),
        ),
        (
            "gdal-pair.2",
            &["-ot", "Int16", "-co", "COMPRESS=DEFLATE"],
            win(x0 + nx / 2, nx / 2),
        ),
    ];
    for (name, options, srcwin) in variants {
        let out = t(&format!("{name}.tif"));
        let srcwin: Vec<&str> = srcwin.iter().map(String::as_str).collect();
        let args = [
            &["-q", "-a_srs", "EPSG:4326"][..],
            options,
            &["-srcwin"],
            &srcwin,
            &[ETOPO5, &out],
        ]
        .concat();
        command("gdal_translate", &args);
        write_seed(
            "geotiff",
            &format!("{name}.tif"),
            &std::fs::read(&out).expect("GDAL's GeoTIFF"),
        );
    }
    // One SRTM tile from ETOPO5 (resampled to 3″), its first 4 KB as the repeated data.
    let h = 0.5 / 1200.0;
    let hgt = t("N46E010.hgt");
    let ullr = [10.0 - h, 47.0 + h, 11.0 + h, 46.0 - h].map(|v| v.to_string());
    let ullr: Vec<&str> = ullr.iter().map(String::as_str).collect();
    let args = [
        &[
            "-q",
            "-of",
            "SRTMHGT",
            "-ot",
            "Int16",
            "-a_nodata",
            "none",
            "-r",
            "bilinear",
        ][..],
        &[
            "-outsize", "1201", "1201", "-projwin", "10", "47", "11", "46", "-a_ullr",
        ],
        &ullr,
        &[ETOPO5, &hgt],
    ]
    .concat();
    command("gdal_translate", &args);
    let data = std::fs::read(&hgt).expect("GDAL's .hgt");
    for (name, names) in [
        ("alps-pair", "N46E010.hgt\nN46E011.hgt\n"),
        ("south-west", "s01w072.HGT\n"),
    ] {
        let mut seed = names.as_bytes().to_vec();
        seed.push(b'@');
        seed.push(1);
        seed.extend_from_slice(&data[..4096]);
        write_seed("hgt", &format!("{name}.hgt"), &seed);
    }
}
