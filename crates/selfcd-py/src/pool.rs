//! The engine's thread pool, as the extension sets it up on import.
//!
//! When the pool has one thread per CPU the process may use (the default),
//! each pool thread is pinned to its own CPU (Linux). Why: between two
//! calls a Python caller keeps running on one core while an idle pool
//! thread yields there for a while before it sleeps (rayon's idle loop);
//! the next call then started with both pool threads on one core and the
//! other idle for milliseconds, until the scheduler moved one (the body's
//! one-shot from Python after 20 ms of busy Python, two threads: 8.9-10.2
//! ms against 6.2-7.2 back to back; BENCHMARKS.md, twenty-fifth landing).
//! Pinned threads start every call on their own cores. A smaller pool
//! (`RAYON_NUM_THREADS`, or a CPU quota below the allowed set, which the
//! default pool size follows) is not pinned: which cores are free for it is
//! not known. `SELFCD_PIN_THREADS=0` turns pinning off. Pool threads are
//! named `selfcd-<i>`.

/// Builds rayon's global pool as the module doc says; nothing when a pool
/// already exists (built by another extension in this process).
pub fn init() {
    let cpus = allowed_cpus();
    let threads = pool_size();
    let pin = threads > 1
        && threads == cpus.len()
        && std::env::var("SELFCD_PIN_THREADS").map_or(true, |v| v.trim() != "0");
    let mut builder = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("selfcd-{i}"));
    if pin {
        builder = builder.start_handler(move |i| pin_to(cpus[i]));
    }
    let _ = builder.build_global();
}

/// Rayon's default pool size: `RAYON_NUM_THREADS` when a positive integer,
/// else the CPUs available to the process (its allowed set, or its CPU
/// quota where that is lower).
fn pool_size() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// The CPUs this process may run on, in increasing order (empty where not known).
#[cfg(target_os = "linux")]
fn allowed_cpus() -> Vec<usize> {
    // SAFETY: `set` is a plain bit set, zeroed, that sched_getaffinity fills.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
            return Vec::new();
        }
        (0..libc::CPU_SETSIZE as usize)
            .filter(|&c| libc::CPU_ISSET(c, &set))
            .collect()
    }
}

#[cfg(not(target_os = "linux"))]
fn allowed_cpus() -> Vec<usize> {
    Vec::new()
}

/// Pins the calling thread to `cpu` (best effort: a refusal leaves it free).
#[cfg(target_os = "linux")]
fn pin_to(cpu: usize) {
    // SAFETY: as above; sched_setaffinity only reads the set.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
    }
}

#[cfg(not(target_os = "linux"))]
fn pin_to(_cpu: usize) {}
