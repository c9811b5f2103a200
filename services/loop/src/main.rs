//! `gfsvo-loop`: the loop stage of the GFS-VO pipeline as a process (loop closing: place recognition, verification, pose graph; the mapper applies its corrections).
//! Run by `gfsvo run` or as a systemd service; `--help` lists the arguments.

fn main() -> std::process::ExitCode {
    gfs_pipeline::service::service_main(gfs_ipc::Stage::Loop)
}
