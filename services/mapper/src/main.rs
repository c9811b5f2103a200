//! `gfsvo-mapper`: the mapper stage of the GFS-VO pipeline as a process (local mapping: keyframes, landmarks, local BA with structural and Manhattan terms).
//! Run by `gfsvo run` or as a systemd service; `--help` lists the arguments.

fn main() -> std::process::ExitCode {
    gfs_pipeline::service::service_main(gfs_ipc::Stage::Mapper)
}
