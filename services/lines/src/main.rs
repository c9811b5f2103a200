//! `gfsvo-lines`: the lines stage of the GFS-VO pipeline as a process (EDLines + joining + LBD + homogenisation + 3D lines of every frame).
//! Run by `gfsvo run` or as a systemd service; `--help` lists the arguments.

fn main() -> std::process::ExitCode {
    gfs_pipeline::service::service_main(gfs_ipc::Stage::Lines)
}
