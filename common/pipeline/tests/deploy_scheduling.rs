//! The systemd units in deploy/systemd/ start each stage with the scheduling the
//! supervisor gives it by default ([pipeline.scheduling]), so that a run under systemd
//! and a run under `gfsvo run` have the same priorities.

use gfs_ipc::Stage;
use gfs_pipeline::scheduling::SchedulingConfig;

fn unit(stage: Stage) -> String {
    let path = format!(
        "{}/../../deploy/systemd/gfsvo-{}@.service",
        env!("CARGO_MANIFEST_DIR"),
        stage.name()
    );
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn setting<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    text.lines()
        .filter_map(|l| l.strip_prefix(key)?.strip_prefix('='))
        .next_back()
}

#[test]
fn every_stage_unit_has_the_default_scheduling() {
    for stage in Stage::ALL {
        let text = unit(stage);
        let wanted = SchedulingConfig::default_for(stage);
        let nice: i32 = setting(&text, "Nice")
            .unwrap_or_else(|| panic!("{}: no Nice=", stage.name()))
            .parse()
            .unwrap();
        assert_eq!(nice, wanted.nice, "{}", stage.name());
        assert_eq!(
            setting(&text, "CPUSchedulingPolicy"),
            Some(wanted.policy.name()),
            "{}",
            stage.name()
        );
        assert_eq!(setting(&text, "CPUAffinity"), None, "{}", stage.name());
    }
}
