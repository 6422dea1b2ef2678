//! How long two threads take to hand a value back and forth: the cost under every split of the
//! step's passes over two cores, and the reason two threads can run a small level slower than
//! one (docs/performance.md, "Two cores").
//!
//! `cargo run --release --example handover` prints the mean round trip of five sets of 200 000
//! handovers. Two cores that share a cache answer in well under 150 ns; two far apart (on
//! different dies, as a virtual machine's host may place them) take 300 ns and more.

use std::hint::spin_loop;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Handovers per set.
const ROUNDS: u64 = 200_000;

fn main() {
    for _ in 0..5 {
        let turn = Arc::new(AtomicU64::new(0));
        let other = {
            let turn = turn.clone();
            std::thread::spawn(move || {
                for i in 0..ROUNDS {
                    while turn.load(Ordering::Acquire) != 2 * i + 1 {
                        spin_loop();
                    }
                    turn.store(2 * i + 2, Ordering::Release);
                }
            })
        };
        let started = Instant::now();
        for i in 0..ROUNDS {
            turn.store(2 * i + 1, Ordering::Release);
            while turn.load(Ordering::Acquire) != 2 * i + 2 {
                spin_loop();
            }
        }
        let ns = started.elapsed().as_secs_f64() * 1e9 / ROUNDS as f64;
        other
            .join()
            .expect("the other thread hands back every round");
        println!("round trip {ns:.0} ns");
    }
}
