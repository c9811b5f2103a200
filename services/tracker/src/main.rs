//! `gfsvo-tracker`: the tracker stage of the GFS-VO pipeline as a process (tracks every frame against the local map and publishes its pose).
//! Run by `gfsvo run` or as a systemd service; `--help` lists the arguments.

fn main() -> std::process::ExitCode {
    gfs_pipeline::service::service_main(gfs_ipc::Stage::Tracker)
}
