//! The systemd user unit: `systemd-analyze` (Debian's `systemd`, installed by
//! `scripts/test.sh`) rates its sandbox and checks that it loads, with the unit's
//! commands pointed at the binary under test and the example config.

use std::process::Command;

mod common;
use common::root;

fn systemd_analyze(args: &[&str]) -> (bool, String) {
    let out = Command::new("systemd-analyze")
        .args(args)
        .output()
        .expect("cannot run systemd-analyze (bash scripts/test.sh installs systemd)");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

#[test]
fn the_unit_is_sandboxed_to_an_exposure_of_at_most_2_5() {
    let unit = root().join("systemd/onomato.service");
    let (_, text) = systemd_analyze(&["security", "--offline=yes", unit.to_str().unwrap()]);
    let exposure: f64 = text
        .lines()
        .find_map(|l| {
            l.split("Overall exposure level for onomato.service:")
                .nth(1)
        })
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no exposure level in:\n{text}"));
    assert!(exposure <= 2.5, "exposure {exposure}:\n{text}");
}

#[test]
fn the_unit_loads_with_its_commands_pointed_at_this_build() {
    let unit = std::fs::read_to_string(root().join("systemd/onomato.service")).unwrap();
    let local = unit
        .replace("%h/.cargo/bin/onomato", env!("CARGO_BIN_EXE_onomato"))
        .replace(
            "%h/.config/onomato/onomato.toml",
            root().join("config/onomato.toml").to_str().unwrap(),
        );
    assert!(
        !local.contains("%h"),
        "a path the test does not replace:\n{local}"
    );
    let dir = common::temp_dir("unit");
    let path = dir.join("onomato.service");
    std::fs::write(&path, local).unwrap();
    let (ok, text) = systemd_analyze(&["verify", path.to_str().unwrap()]);
    assert!(
        ok && text.trim().is_empty(),
        "systemd-analyze verify:\n{text}"
    );
    // What the unit's start runs first passes on the example config.
    let check = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args(["check", "--config"])
        .arg(root().join("config/onomato.toml"))
        .output()
        .unwrap();
    assert!(check.status.success(), "{check:?}");
}
