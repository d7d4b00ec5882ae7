//! Prints an OpenEXR file's header in the manner of OpenEXR's `exrheader`: every attribute with
//! its type, then the layers its channel names form (`albedo.R` belongs to layer `albedo`).
//! Reads with the `exr` crate, so it works where OpenEXR's tools are not installed:
//! `cargo run -p irr-render --example exrheader -- out/cornell-box.exr`.

use exr::meta::attribute::{AttributeValue, Chromaticities, Text};
use exr::meta::header::Header;
use std::collections::BTreeMap;
use std::process::ExitCode;

fn text(t: &Text) -> String {
    format!(
        "\"{}\"",
        String::from_utf8_lossy(t.as_slice()).escape_debug()
    )
}

fn matrix(m: &[f32; 16]) -> String {
    (0..4)
        .map(|r| {
            let row: Vec<String> = (0..4).map(|c| format!("{}", m[4 * r + c])).collect();
            format!("\n    ({})", row.join(" "))
        })
        .collect()
}

fn chromaticities(c: &Chromaticities) -> String {
    format!(
        "\n    red   ({} {})\n    green ({} {})\n    blue  ({} {})\n    white ({} {})",
        c.red.0, c.red.1, c.green.0, c.green.1, c.blue.0, c.blue.1, c.white.0, c.white.1
    )
}

/// An attribute's type name as OpenEXR spells it, and its value as `exrheader` prints it.
fn value(v: &AttributeValue) -> (&'static str, String) {
    match v {
        AttributeValue::Text(t) => ("string", text(t)),
        AttributeValue::TextVector(ts) => (
            "stringvector",
            ts.iter().map(|t| format!("\n    {}", text(t))).collect(),
        ),
        AttributeValue::F32(f) => ("float", f.to_string()),
        AttributeValue::F64(f) => ("double", f.to_string()),
        AttributeValue::I32(i) => ("int", i.to_string()),
        AttributeValue::Matrix4x4(m) => ("m44f", matrix(m)),
        AttributeValue::Chromaticities(c) => ("chromaticities", chromaticities(c)),
        AttributeValue::FloatVec2(v) => ("v2f", format!("({} {})", v.0, v.1)),
        AttributeValue::IntVec2(v) => ("v2i", format!("({} {})", v.0, v.1)),
        other => ("(other)", format!("{other:?}")),
    }
}

fn print_header(index: usize, header: &Header) {
    let mut lines: BTreeMap<String, String> = BTreeMap::new();
    let mut put = |name: &str, (ty, v): (&str, String)| {
        let sep = if v.starts_with('\n') { ":" } else { ": " };
        lines.insert(name.to_string(), format!("{name} (type {ty}){sep}{v}"));
    };
    let channels: String = header
        .channels
        .list
        .iter()
        .map(|c| {
            format!(
                "\n    {}, {:?}, sampling {} {}",
                String::from_utf8_lossy(c.name.as_slice()),
                c.sample_type,
                c.sampling.0,
                c.sampling.1
            )
        })
        .collect();
    put("channels", ("chlist", channels));
    put(
        "compression",
        ("compression", format!("{:?}", header.compression)),
    );
    put(
        "lineOrder",
        ("lineOrder", format!("{:?}", header.line_order)),
    );
    let (pos, size) = (header.own_attributes.layer_position, header.layer_size);
    put(
        "dataWindow",
        (
            "box2i",
            format!(
                "({} {}) - ({} {})",
                pos.0,
                pos.1,
                pos.0 + size.0 as i32 - 1,
                pos.1 + size.1 as i32 - 1
            ),
        ),
    );
    let display = &header.shared_attributes.display_window;
    put(
        "displayWindow",
        (
            "box2i",
            format!(
                "({} {}) - ({} {})",
                display.position.0,
                display.position.1,
                display.position.0 + display.size.0 as i32 - 1,
                display.position.1 + display.size.1 as i32 - 1
            ),
        ),
    );
    put(
        "pixelAspectRatio",
        value(&AttributeValue::F32(header.shared_attributes.pixel_aspect)),
    );
    let own = &header.own_attributes;
    put(
        "screenWindowCenter",
        value(&AttributeValue::FloatVec2(own.screen_window_center)),
    );
    put(
        "screenWindowWidth",
        value(&AttributeValue::F32(own.screen_window_width)),
    );
    if let Some(c) = &header.shared_attributes.chromaticities {
        put("chromaticities", value(&AttributeValue::Chromaticities(*c)));
    }
    if let Some(n) = &own.layer_name {
        put("name", value(&AttributeValue::Text(n.clone())));
    }
    if let Some(s) = &own.software_name {
        put("software", value(&AttributeValue::Text(s.clone())));
    }
    if let Some(c) = &own.comments {
        put("comments", value(&AttributeValue::Text(c.clone())));
    }
    if let Some(m) = &own.world_to_camera {
        put("worldToCamera", value(&AttributeValue::Matrix4x4(*m)));
    }
    if let Some(m) = &own.world_to_normalized_device {
        put("worldToNDC", value(&AttributeValue::Matrix4x4(*m)));
    }
    for (name, v) in header
        .shared_attributes
        .other
        .iter()
        .chain(own.other.iter())
    {
        put(&String::from_utf8_lossy(name.as_slice()), value(v));
    }
    println!("part {index}:");
    for line in lines.values() {
        println!("{line}");
    }
    // The layers: channel names grouped by everything before their last dot.
    let mut layers: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for c in &header.channels.list {
        let name = String::from_utf8_lossy(c.name.as_slice()).into_owned();
        let (layer, channel) = match name.rsplit_once('.') {
            Some((l, c)) => (l.to_string(), c.to_string()),
            None => ("(default layer)".to_string(), name),
        };
        layers.entry(layer).or_default().push(channel);
    }
    println!("layers:");
    for (layer, channels) in layers {
        println!("    {layer}: {}", channels.join(", "));
    }
}

fn main() -> ExitCode {
    let Some(path) = std::env::args_os().nth(1) else {
        eprintln!("usage: exrheader FILE.exr");
        return ExitCode::FAILURE;
    };
    let meta = match exr::meta::MetaData::read_from_file(&path, false) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{}: {e}", path.to_string_lossy());
            return ExitCode::FAILURE;
        }
    };
    println!("file {}:\n", path.to_string_lossy());
    let r = meta.requirements;
    println!(
        "file format version: {}, {}{}\n",
        r.file_format_version,
        if r.is_multilayer() {
            "multi-part"
        } else {
            "single part"
        },
        if r.has_long_names { ", long names" } else { "" }
    );
    for (i, header) in meta.headers.iter().enumerate() {
        print_header(i, header);
    }
    ExitCode::SUCCESS
}
