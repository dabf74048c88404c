// The round trip of a cache line between two threads of a 2-thread team: machine context for
// every figure that moves data between cores. On the 2-core VM it changes while the machine
// runs (77-93 ns in one run of clothbench-micro, 363-408 ns in the next: the host places the
// two vCPUs near each other or far apart), and with it the cost of a self-scheduled clause's
// shared counter and of cache lines shared at block borders (README, "Predicting other thread
// counts"). Measured by clothbench-micro's scheduling_overhead benchmarks and by `clothbench
// sweep` before and after every row of 2 or more threads.
#pragma once

namespace clothbench::harness {

/// The median over `samples` samples of `trips` round trips each (ns), measured in a new
/// 2-thread team (one thread spins while the other answers, so it runs a few ms at 1000 x 11).
/// 0 when the machine has fewer than 2 hardware threads (two spinning threads would take
/// turns on one core) or the runtime gives fewer than 2 threads.
double core_round_trip_ns(int trips = 1000, int samples = 11);

/// A placement change between two round trips worth naming: the larger is more than twice the
/// smaller (both measured, i.e. > 0).
bool round_trip_changed(double before_ns, double after_ns);

}  // namespace clothbench::harness
