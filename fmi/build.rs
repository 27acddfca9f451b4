//! Compiles the C shim that formats the printf-style messages FMUs log (see csrc/logger.c).

fn main() {
    println!("cargo::rerun-if-changed=csrc/logger.c");
    cc::Build::new().file("csrc/logger.c").warnings(true).compile("fmi2rs_logger");
}
