//! The FMU's shared library carries its own copy of the unwinder that its panic barrier needs,
//! so `ldd` shows only the C runtime (see `magswarm-static-unwind`).
fn main() {
    magswarm_static_unwind::link_unwinder_statically(magswarm_static_unwind::Artefact::Cdylib);
}
