//! Transport latency of a 640x480 RGB-D frame between two processes over iceoryx2.
//!
//! The parent publishes frames (gray u8 + depth f32 + RGB = 2.46 MB each) on a `frame`
//! topic; a child process (this binary again, started with `GFS_IPC_BENCH_CHILD` set)
//! receives each one, parses it into image views in place and answers on an `ack` topic
//! with its CLOCK_MONOTONIC stamps. One frame is in flight at a time (lockstep), so the
//! numbers are transport, not queueing. Two wait strategies are measured: the subscriber
//! sleeping on the topic's wake-up event, and busy polling.
//!
//! ```text
//! cargo run --release -p gfs-ipc --example transport_bench -- [FRAMES] [WARMUP]
//! ```

use std::process::{Child, Command};
use std::time::{Duration, Instant};

use gfs_core::Image;
use gfs_core::ids::FrameId;
use gfs_ipc::ipc;
use gfs_ipc::{
    FrameLayout, IpcRun, Mode, MsgHeader, RunId, Stage, StageStamp, TopicKind, TopicPublisher,
    TopicQos, TopicSubscriber, frame_view, frame_view_mut, monotonic_ns, topics,
};

const CHILD_ENV: &str = "GFS_IPC_BENCH_CHILD";
const WIDTH: usize = 640;
const HEIGHT: usize = 480;
/// Frame id that tells the child to stop.
const STOP: u64 = u64::MAX;
/// Ack frame id that says "subscribed and ready".
const READY: u64 = u64::MAX - 1;
/// Bound on every wait: a lost message ends the benchmark with an error, not a hang.
const TIMEOUT: Duration = Duration::from_secs(10);

type BoxError = Box<dyn std::error::Error>;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Wait {
    Event,
    Spin,
}

impl Wait {
    fn name(self) -> &'static str {
        match self {
            Wait::Event => "event",
            Wait::Spin => "spin",
        }
    }
}

/// Waits for the next sample of `sub` with `strategy`, at most [`TIMEOUT`].
fn next<T: std::fmt::Debug + gfs_ipc::ZeroCopySend + 'static>(
    sub: &TopicSubscriber<ipc::Service, T>,
    strategy: Wait,
) -> Result<gfs_ipc::TopicSample<ipc::Service, T>, BoxError> {
    let deadline = Instant::now() + TIMEOUT;
    loop {
        if let Some(s) = sub.receive()? {
            return Ok(s);
        }
        let now = Instant::now();
        if now >= deadline {
            return Err(format!("no message on {} within {TIMEOUT:?}", sub.topic()).into());
        }
        match strategy {
            Wait::Event => {
                sub.wait(deadline - now)?;
            }
            Wait::Spin => std::thread::yield_now(),
        }
    }
}

fn qos_frame() -> TopicQos {
    topics::FRAME.qos(Mode::Lockstep)
}

fn qos_ack() -> TopicQos {
    TopicQos::new(Mode::Lockstep, TopicKind::Features)
}

fn child(spec: &str) -> Result<(), BoxError> {
    let (run_id, strategy) = spec.split_once(':').ok_or("bad child spec")?;
    let strategy = if strategy == "spin" {
        Wait::Spin
    } else {
        Wait::Event
    };
    let run = IpcRun::new(RunId::new(run_id)?)?;
    let node = run.node::<ipc::Service>("bench-sub")?;
    let frames =
        TopicSubscriber::<ipc::Service, u8>::create(&run, &node, topics::FRAME.name, &qos_frame())?;
    let acks = TopicPublisher::<ipc::Service, u64>::create(&run, &node, "ack", &qos_ack(), 4)?;
    acks.publish_slice(&MsgHeader::new(FrameId(READY), 0.0), &[0; 4])?;
    loop {
        let sample = next(&frames, strategy)?;
        let received_ns = monotonic_ns();
        let mut header = *sample.user_header();
        if header.frame_id == STOP {
            return Ok(());
        }
        let view = frame_view(&sample)?;
        // Touch one pixel of each plane so the parse cannot be optimised away.
        let probe = u64::from(view.gray().at(WIDTH - 1, HEIGHT - 1))
            + view.depth().at(3, 3).to_bits() as u64
            + view.rgb().map_or(0, |v| u64::from(v.at(5, 5)[2]));
        let parsed_ns = monotonic_ns();
        *header.stamp_mut(Stage::Points) = StageStamp {
            received_ns,
            started_ns: received_ns,
            finished_ns: parsed_ns,
        };
        acks.publish_slice(&header, &[probe, 0, 0, 0])?;
    }
}

struct Fixture {
    gray: Image<u8>,
    depth: Image<f32>,
    rgb: Image<[u8; 3]>,
}

fn fixture() -> Fixture {
    let mut f = Fixture {
        gray: Image::new(WIDTH, HEIGHT),
        depth: Image::new(WIDTH, HEIGHT),
        rgb: Image::new(WIDTH, HEIGHT),
    };
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let i = x * 7 + y * 13;
            f.gray.set(x, y, (i % 251) as u8);
            f.depth.set(x, y, 0.5 + (i % 1000) as f32 * 0.004);
            f.rgb.set(
                x,
                y,
                [(i % 256) as u8, (i / 3 % 256) as u8, (i / 7 % 256) as u8],
            );
        }
    }
    f
}

/// Per-frame timings in ns.
#[derive(Default)]
struct Samples {
    copy_in: Vec<u64>,
    send_to_receive: Vec<u64>,
    send_to_view: Vec<u64>,
    publish_to_view: Vec<u64>,
}

fn spawn_child(run: &IpcRun, strategy: Wait) -> Result<Child, BoxError> {
    Ok(Command::new(std::env::current_exe()?)
        .env(CHILD_ENV, format!("{}:{}", run.run_id(), strategy.name()))
        .spawn()?)
}

/// Waits for the child to exit, killing it after [`TIMEOUT`].
fn reap(mut child: Child) -> Result<(), BoxError> {
    let deadline = Instant::now() + TIMEOUT;
    while Instant::now() < deadline {
        if let Some(status) = child.try_wait()? {
            return if status.success() {
                Ok(())
            } else {
                Err(format!("child exited with {status}").into())
            };
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill()?;
    child.wait()?;
    Err("child did not stop; killed".into())
}

fn measure(strategy: Wait, frames: usize, warmup: usize, f: &Fixture) -> Result<Samples, BoxError> {
    let run = IpcRun::new(RunId::unique("bench")?)?;
    let mut samples = Samples::default();
    {
        let node = run.node::<ipc::Service>("bench-pub")?;
        let layout = FrameLayout::new(WIDTH, HEIGHT, true)?;
        let publisher = TopicPublisher::<ipc::Service, u8>::create(
            &run,
            &node,
            topics::FRAME.name,
            &qos_frame(),
            layout.byte_len(),
        )?;
        let acks = TopicSubscriber::<ipc::Service, u64>::create(&run, &node, "ack", &qos_ack())?;
        let child = spawn_child(&run, strategy)?;
        let ready = next(&acks, Wait::Event)?;
        if ready.user_header().frame_id != READY {
            return Err("child did not say ready".into());
        }
        drop(ready);
        let expected_probe = u64::from(f.gray.get(WIDTH - 1, HEIGHT - 1).unwrap_or(0))
            + f.depth.get(3, 3).unwrap_or(0.0).to_bits() as u64
            + u64::from(f.rgb.get(5, 5).unwrap_or([0; 3])[2]);
        for k in 0..warmup + frames {
            let t0 = monotonic_ns();
            let mut sample =
                publisher.loan_frame(&MsgHeader::new(FrameId(k as u64), 0.0), &layout)?;
            {
                let planes = frame_view_mut(&mut sample, &layout)?;
                planes.gray.copy_from_slice(f.gray.as_slice());
                planes.depth.copy_from_slice(f.depth.as_slice());
                if let Some(rgb) = planes.rgb {
                    rgb.copy_from_slice(f.rgb.as_slice());
                }
            }
            let t1 = monotonic_ns();
            *sample.user_header_mut().stamp_mut(Stage::Source) = StageStamp {
                received_ns: t0,
                started_ns: t0,
                finished_ns: t1,
            };
            publisher.send(sample)?;
            let ack = next(&acks, strategy)?;
            let h = ack.user_header();
            if h.frame_id != k as u64 || ack.payload().first() != Some(&expected_probe) {
                return Err(format!(
                    "frame {k}: wrong ack (id {}, payload {:?})",
                    h.frame_id,
                    ack.payload()
                )
                .into());
            }
            if k >= warmup {
                let p = h.stamp(Stage::Points);
                samples.copy_in.push(t1 - t0);
                samples
                    .send_to_receive
                    .push(p.received_ns.saturating_sub(t1));
                samples.send_to_view.push(p.finished_ns.saturating_sub(t1));
                samples
                    .publish_to_view
                    .push(p.finished_ns.saturating_sub(t0));
            }
        }
        publisher.send(publisher.loan(&MsgHeader::new(FrameId(STOP), 0.0), 0)?)?;
        reap(child)?;
        let report = run.cleanup_dead_nodes::<ipc::Service>()?;
        if report.cleaned + report.failed > 0 {
            eprintln!(
                "note: {} dead node(s) cleaned",
                report.cleaned + report.failed
            );
        }
    }
    let left = run.finish();
    if !left.is_empty() {
        return Err(format!("iceoryx2 files of run {} left: {left:?}", run.run_id()).into());
    }
    Ok(samples)
}

fn percentile(sorted: &[u64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let idx = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[idx.min(sorted.len() - 1)] as f64 / 1e3
}

fn print_row(name: &str, values: &[u64]) {
    let mut v = values.to_vec();
    v.sort_unstable();
    println!(
        "  {name:<26} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
        percentile(&v, 0.5),
        percentile(&v, 0.9),
        percentile(&v, 0.99),
        percentile(&v, 1.0)
    );
}

fn parent() -> Result<(), BoxError> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().map_or(Ok(2000), |a| a.parse())?;
    let warmup: usize = args.next().map_or(Ok(100), |a| a.parse())?;
    let f = fixture();
    let bytes = FrameLayout::new(WIDTH, HEIGHT, true)?.byte_len();
    println!(
        "transport latency, {WIDTH}x{HEIGHT} RGB-D frame ({:.2} MB: gray u8 + depth f32 + rgb), \
         {frames} frames after {warmup} warm-up, one in flight, two processes over iceoryx2 ipc",
        bytes as f64 / 1e6
    );
    // The tails depend on what else runs on the machine: say so with the numbers.
    if let Ok(load) = std::fs::read_to_string("/proc/loadavg") {
        println!(
            "load average {} on {} cores",
            load.split_whitespace()
                .take(3)
                .collect::<Vec<_>>()
                .join(" "),
            std::thread::available_parallelism().map_or(0, |n| n.get())
        );
    }
    for strategy in [Wait::Event, Wait::Spin] {
        let s = measure(strategy, frames, warmup, &f)?;
        println!("subscriber waits by {} (µs):", strategy.name());
        println!(
            "  {:<26} {:>9} {:>9} {:>9} {:>9}",
            "", "median", "p90", "p99", "max"
        );
        print_row("copy into sample", &s.copy_in);
        print_row("send -> received", &s.send_to_receive);
        print_row("send -> parsed views", &s.send_to_view);
        print_row("loan+copy+send -> views", &s.publish_to_view);
    }
    Ok(())
}

fn main() {
    let result = match std::env::var(CHILD_ENV) {
        Ok(spec) => child(&spec),
        Err(_) => parent(),
    };
    if let Err(e) = result {
        eprintln!("transport_bench: {e}");
        std::process::exit(1);
    }
}
