//! `gfsvo bench transport`: latency of a 640x480 RGB-D frame between two processes over
//! iceoryx2.
//!
//! This process publishes frames (gray u8 + depth f32 + RGB = 2.46 MB each) on a `frame`
//! topic; a subscriber process (this executable again, `bench transport --subscriber`)
//! receives each one, parses it into image views in place and answers on an `ack` topic
//! with its CLOCK_MONOTONIC stamps. One frame is in flight at a time (lockstep), so the
//! numbers are transport, not queueing. Two wait strategies are measured: the subscriber
//! sleeping on the topic's wake-up event, and busy polling.

use super::stats::Summary;
use crate::CliResult;
use clap::Args;
use gfs_core::Image;
use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_ipc::{
    FrameLayout, IpcRun, Mode, MsgHeader, RunId, Stage, StageStamp, TopicKind, TopicPublisher,
    TopicQos, TopicSample, TopicSubscriber, ZeroCopySend, frame_view, frame_view_mut, ipc,
    monotonic_ns, topics,
};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

const WIDTH: usize = 640;
const HEIGHT: usize = 480;
/// Frame id that tells the subscriber to stop.
const STOP: u64 = u64::MAX;
/// Ack frame id that says "subscribed and ready".
const READY: u64 = u64::MAX - 1;
/// Bound on every wait: a lost message ends the benchmark with an error, not a hang.
const TIMEOUT: Duration = Duration::from_secs(10);

/// Arguments of `gfsvo bench transport`.
#[derive(Args)]
pub struct TransportArgs {
    /// Frames timed per wait strategy.
    #[arg(long, default_value_t = 2000)]
    pub frames: usize,
    /// Frames sent before timing starts (page faults, connection set-up).
    #[arg(long, default_value_t = 100)]
    pub warmup: usize,
    /// Internal: run as the subscriber process of run `RUN-ID:event|spin`.
    #[arg(long, hide = true)]
    pub subscriber: Option<String>,
}

/// How the receiving side waits for the next sample.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Wait {
    /// Sleep on the topic's iceoryx2 event.
    Event,
    /// Poll `receive` with `yield_now` in between.
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

/// Runs the benchmark (or, with `--subscriber`, its subscriber process).
pub fn run(args: &TransportArgs) -> CliResult {
    if let Some(spec) = &args.subscriber {
        return subscriber(spec);
    }
    let fixture = Fixture::new();
    let bytes = FrameLayout::new(WIDTH, HEIGHT, true)?.byte_len();
    println!(
        "transport latency, {WIDTH}x{HEIGHT} RGB-D frame ({:.2} MB: gray u8 + depth f32 + rgb), \
         {} frames after {} warm-up, one in flight, two processes over iceoryx2 ipc",
        bytes as f64 / 1e6,
        args.frames,
        args.warmup
    );
    // The tails depend on what else runs on the machine: say so with the numbers.
    if let Ok(load) = std::fs::read_to_string("/proc/loadavg") {
        let load: Vec<&str> = load.split_whitespace().take(3).collect();
        println!(
            "load average {} on {} cores",
            load.join(" "),
            std::thread::available_parallelism().map_or(0, |n| n.get())
        );
    }
    for strategy in [Wait::Event, Wait::Spin] {
        let s = measure(strategy, args.frames, args.warmup, &fixture)?;
        println!("subscriber waits by {} (µs):", strategy.name());
        println!(
            "  {:<26} {:>9} {:>9} {:>9} {:>9}",
            "", "median", "p90", "p99", "max"
        );
        print_row("copy into sample", s.copy_in);
        print_row("send -> received", s.send_to_receive);
        print_row("send -> parsed views", s.send_to_view);
        print_row("loan+copy+send -> views", s.publish_to_view);
    }
    Ok(())
}

fn print_row(name: &str, mut values_us: Vec<f64>) {
    let s = Summary::of(&mut values_us);
    println!(
        "  {name:<26} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
        s.median, s.p90, s.p99, s.max
    );
}

/// Waits for the next sample of `sub` with `strategy`, at most [`TIMEOUT`].
fn next<T: std::fmt::Debug + ZeroCopySend + 'static>(
    sub: &TopicSubscriber<ipc::Service, T>,
    strategy: Wait,
) -> CliResult<TopicSample<ipc::Service, T>> {
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

fn frame_qos() -> TopicQos {
    topics::FRAME.qos(Mode::Lockstep)
}

fn ack_qos() -> TopicQos {
    TopicQos::new(Mode::Lockstep, TopicKind::Features)
}

/// The subscriber process: acknowledges every frame with its receive / parse stamps
/// until the stop frame.
fn subscriber(spec: &str) -> CliResult {
    let (run_id, strategy) = spec
        .split_once(':')
        .ok_or_else(|| format!("--subscriber {spec:?}: expected RUN-ID:event|spin"))?;
    let strategy = if strategy == "spin" {
        Wait::Spin
    } else {
        Wait::Event
    };
    let run = IpcRun::new(RunId::new(run_id)?)?;
    let node = run.node::<ipc::Service>("bench-sub")?;
    let frames =
        TopicSubscriber::<ipc::Service, u8>::create(&run, &node, topics::FRAME.name, &frame_qos())?;
    let acks = TopicPublisher::<ipc::Service, u64>::create(&run, &node, "ack", &ack_qos(), 1)?;
    acks.publish_slice(&MsgHeader::new(FrameId(READY), Stamp::default()), &[0])?;
    loop {
        let sample = next(&frames, strategy)?;
        let received_ns = monotonic_ns();
        let mut header = *sample.user_header();
        if header.frame_id == STOP {
            return Ok(());
        }
        let probe = probe_of(&frame_view(&sample)?);
        let parsed_ns = monotonic_ns();
        *header.stamp_mut(Stage::Points) = StageStamp {
            received_ns,
            started_ns: received_ns,
            finished_ns: parsed_ns,
        };
        acks.publish_slice(&header, &[probe])?;
    }
}

/// One pixel of each plane, so that the parse cannot be optimised away and the
/// publisher can check the subscriber saw its frame.
fn probe_of(view: &gfs_ipc::FrameView<'_>) -> u64 {
    u64::from(view.gray().at(WIDTH - 1, HEIGHT - 1))
        + u64::from(view.depth().at(3, 3).to_bits())
        + view.rgb().map_or(0, |v| u64::from(v.at(5, 5)[2]))
}

/// The frame sent every time.
struct Fixture {
    gray: Image<u8>,
    depth: Image<f32>,
    rgb: Image<[u8; 3]>,
}

impl Fixture {
    fn new() -> Self {
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
                let rgb = [i % 256, i / 3 % 256, i / 7 % 256].map(|c| c as u8);
                f.rgb.set(x, y, rgb);
            }
        }
        f
    }

    fn probe(&self) -> u64 {
        u64::from(self.gray.get(WIDTH - 1, HEIGHT - 1).unwrap_or(0))
            + u64::from(self.depth.get(3, 3).unwrap_or(0.0).to_bits())
            + u64::from(self.rgb.get(5, 5).unwrap_or([0; 3])[2])
    }
}

/// Per-frame timings in µs.
#[derive(Default)]
struct Samples {
    copy_in: Vec<f64>,
    send_to_receive: Vec<f64>,
    send_to_view: Vec<f64>,
    publish_to_view: Vec<f64>,
}

fn us(from_ns: u64, to_ns: u64) -> f64 {
    to_ns.saturating_sub(from_ns) as f64 / 1e3
}

fn spawn_subscriber(run: &IpcRun, strategy: Wait) -> CliResult<Child> {
    let spec = format!("{}:{}", run.run_id(), strategy.name());
    Ok(Command::new(std::env::current_exe()?)
        .args(["bench", "transport", "--subscriber", &spec])
        .spawn()?)
}

/// Waits for the subscriber to exit, killing it after [`TIMEOUT`].
fn reap(mut child: Child) -> CliResult {
    let deadline = Instant::now() + TIMEOUT;
    while Instant::now() < deadline {
        if let Some(status) = child.try_wait()? {
            return if status.success() {
                Ok(())
            } else {
                Err(format!("subscriber exited with {status}").into())
            };
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill()?;
    child.wait()?;
    Err("subscriber did not stop; killed".into())
}

/// One benchmark run in its own iceoryx2 run (cleaned up and checked afterwards).
fn measure(strategy: Wait, frames: usize, warmup: usize, f: &Fixture) -> CliResult<Samples> {
    let run = IpcRun::new(RunId::unique("bench")?)?;
    let samples = publish_all(&run, strategy, frames, warmup, f);
    // Clean up after a failed subscriber too, then report the first error.
    let report = run.cleanup_dead_nodes::<ipc::Service>()?;
    if report.cleaned + report.failed > 0 {
        eprintln!(
            "note: {} dead node(s) cleaned",
            report.cleaned + report.failed
        );
    }
    let samples = samples?;
    let left = run.finish();
    if !left.is_empty() {
        return Err(format!("iceoryx2 files of run {} left: {left:?}", run.run_id()).into());
    }
    Ok(samples)
}

/// The publisher side: starts the subscriber process, sends `warmup + frames` frames one
/// at a time, collects the acknowledged stamps of the last `frames`, stops the subscriber.
fn publish_all(
    run: &IpcRun,
    strategy: Wait,
    frames: usize,
    warmup: usize,
    f: &Fixture,
) -> CliResult<Samples> {
    let node = run.node::<ipc::Service>("bench-pub")?;
    let layout = FrameLayout::new(WIDTH, HEIGHT, true)?;
    let publisher = TopicPublisher::<ipc::Service, u8>::create(
        run,
        &node,
        topics::FRAME.name,
        &frame_qos(),
        layout.byte_len(),
    )?;
    let acks = TopicSubscriber::<ipc::Service, u64>::create(run, &node, "ack", &ack_qos())?;
    let mut child = spawn_subscriber(run, strategy)?;
    match exchange(&publisher, &acks, strategy, frames, warmup, f) {
        Ok(samples) => {
            publisher.send(publisher.loan(&MsgHeader::new(FrameId(STOP), Stamp::default()), 0)?)?;
            reap(child)?;
            Ok(samples)
        }
        Err(e) => {
            // Best effort: the benchmark's own error is the one worth reporting.
            let _ = child.kill();
            let _ = child.wait();
            Err(e)
        }
    }
}

/// Waits for the subscriber's "ready", then the timed frames.
fn exchange(
    publisher: &TopicPublisher<ipc::Service, u8>,
    acks: &TopicSubscriber<ipc::Service, u64>,
    strategy: Wait,
    frames: usize,
    warmup: usize,
    f: &Fixture,
) -> CliResult<Samples> {
    let ready = next(acks, Wait::Event)?;
    if ready.user_header().frame_id != READY {
        return Err("the subscriber did not say ready".into());
    }
    drop(ready);
    let layout = FrameLayout::new(WIDTH, HEIGHT, true)?;
    let expected = f.probe();
    let mut samples = Samples::default();
    for k in 0..(warmup + frames) as u64 {
        let t0 = monotonic_ns();
        let mut sample =
            publisher.loan_frame(&MsgHeader::new(FrameId(k), Stamp::default()), &layout)?;
        {
            let planes = frame_view_mut(&mut sample, &layout)?;
            planes.gray.copy_from_slice(f.gray.as_slice());
            planes.depth.copy_from_slice(f.depth.as_slice());
            if let Some(rgb) = planes.rgb {
                rgb.copy_from_slice(f.rgb.as_slice());
            }
        }
        let t1 = monotonic_ns();
        publisher.send(sample)?;
        let ack = next(acks, strategy)?;
        let h = ack.user_header();
        if h.frame_id != k || ack.payload().first() != Some(&expected) {
            return Err(format!(
                "frame {k}: wrong ack (id {}, payload {:?})",
                h.frame_id,
                ack.payload()
            )
            .into());
        }
        if k >= warmup as u64 {
            let p = h.stamp(Stage::Points);
            samples.copy_in.push(us(t0, t1));
            samples.send_to_receive.push(us(t1, p.received_ns));
            samples.send_to_view.push(us(t1, p.finished_ns));
            samples.publish_to_view.push(us(t0, p.finished_ns));
        }
    }
    Ok(samples)
}
