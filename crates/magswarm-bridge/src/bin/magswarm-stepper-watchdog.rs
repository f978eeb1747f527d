//! `magswarm-stepper-watchdog`: owns the stepper's serial line for a bridge (or the rig FMU)
//! and stops the motor when that process dies or goes silent. Started by the bridge with the
//! link on its standard input; not meant to be run by hand (see `magswarm_bridge::watchdog`).

use std::os::fd::AsFd;
use std::os::unix::net::UnixStream;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use magswarm_bridge::watchdog::guard::{self, Ended};
use magswarm_bridge::watchdog::GuardSpec;

fn main() -> ExitCode {
    let spec = match GuardSpec::from_args(std::env::args().skip(1)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let link = match std::io::stdin().as_fd().try_clone_to_owned() {
        Ok(fd) => UnixStream::from(fd),
        Err(e) => {
            eprintln!("magswarm-stepper-watchdog: no link on standard input: {e}");
            return ExitCode::from(2);
        }
    };
    if link.peer_addr().is_err() {
        eprintln!(
            "magswarm-stepper-watchdog: standard input is not a socket: this program is started \
             by magswarm-bridge (and the rig FMU), which hand it their end of the link"
        );
        return ExitCode::from(2);
    }
    let signal = Arc::new(AtomicBool::new(false));
    for s in [
        signal_hook::consts::SIGTERM,
        signal_hook::consts::SIGINT,
        signal_hook::consts::SIGHUP,
    ] {
        if let Err(e) = signal_hook::flag::register(s, signal.clone()) {
            eprintln!("magswarm-stepper-watchdog: installing a signal handler: {e}");
            return ExitCode::from(2);
        }
    }
    match guard::run(&spec, &link, &signal) {
        Ok(Ended::Bye) => ExitCode::SUCCESS,
        Ok(Ended::BridgeGone) => {
            eprintln!(
                "magswarm-stepper-watchdog: the bridge is gone (its end of the link closed): \
                 motor stopped (MST to {})",
                spec.device
            );
            ExitCode::SUCCESS
        }
        Ok(Ended::Signal) => {
            eprintln!("magswarm-stepper-watchdog: stopped by a signal: motor stopped (MST)");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("magswarm-stepper-watchdog: {e}");
            ExitCode::from(1)
        }
    }
}
