//! The stepper watchdog ships inside MagSwarmRig.fmu: it carries its own copy of the unwinder,
//! so `ldd` shows only the C runtime there too (see `magswarm-static-unwind`).
fn main() {
    magswarm_static_unwind::link_unwinder_statically(magswarm_static_unwind::Artefact::Bin(
        "magswarm-stepper-watchdog",
    ));
}
