//! deploy/iceoryx2.toml (for programs that join a run through iceoryx2 directly) must
//! describe the config every gfs-ipc node of run "cam0" uses.

use gfs_ipc::{IpcRun, RunId};
use iceoryx2::config::Config;
use iceoryx2::prelude::{FilePath, SemanticString};

#[test]
fn deploy_file_matches_the_run_config() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../deploy/iceoryx2.toml");
    let from_file = Config::from_file(&FilePath::new(path.as_bytes()).unwrap()).unwrap();
    let run = IpcRun::new(RunId::new("cam0").unwrap()).unwrap();
    assert_eq!(from_file.global.prefix.as_bytes(), b"gfsvo_cam0_");
    assert_eq!(from_file.global.root_path().as_bytes(), b"/tmp/iceoryx2/");
    assert_eq!(&from_file, run.config());
}
