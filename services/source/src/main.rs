//! `gfsvo-source`: the source stage of the GFS-VO pipeline as a process (decodes dataset frames and publishes them (undistorted gray + depth in metres)).
//! Run by `gfsvo run` or as a systemd service; `--help` lists the arguments.

fn main() -> std::process::ExitCode {
    gfs_pipeline::service::service_main(gfs_ipc::Stage::Source)
}
