//! `gfsvo-planes`: the planes stage of the GFS-VO pipeline as a process (plane normals and Manhattan axes of every frame).
//! Run by `gfsvo run` or as a systemd service; `--help` lists the arguments.

fn main() -> std::process::ExitCode {
    gfs_pipeline::service::service_main(gfs_ipc::Stage::Planes)
}
