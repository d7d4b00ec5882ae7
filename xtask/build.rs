//! With the `denoise` feature: records Intel Open Image Denoise's folder (OIDN_DIR/lib, which
//! irr-render's build script checks) as a run-time search path of this package's binaries and
//! tests, so they start without LD_LIBRARY_PATH.
fn main() {
    println!("cargo::rerun-if-env-changed=OIDN_DIR");
    if let (Some(_), Some(dir)) = (
        std::env::var_os("CARGO_FEATURE_DENOISE"),
        std::env::var_os("OIDN_DIR"),
    ) {
        let lib = std::path::Path::new(&dir).join("lib");
        println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}
