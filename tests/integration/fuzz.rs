//! Mutation fuzzing of every reader, deterministic (a fixed seed): a small built folder is damaged
//! one file at a time — truncated, bit-flipped, overwritten, its header made to lie about sizes and
//! formats, its manifest made to lie about the files — and `tmlut check` and `tmlut inspect` read
//! it, each run in its own process under a memory and a time limit (`common`). Configurations and
//! scenes are mutated and planned the same way; commit journals that name paths outside the folder
//! are handed to `tmlut build`, which must refuse them and touch nothing. Links are planted under
//! the names a build writes (its lock, a table, its staging folder and temporaries, the error
//! maps' folder), pointing at a file and a folder outside: neither may change. FIFOs take the
//! place of every kind of input (manifest, table, configuration, scene, budgets, form, journal,
//! cache entry): no run may wait on one. A scene build's cache is handed hostile entries (values
//! edited and the hash line recomputed, another entry's contents under a key, links in place of
//! entries and temporaries): its tables must be those of a build without the cache. Nothing may
//! panic, abort or hang, and no damaged table may pass `check`.
//!
//! `FUZZ_CASES` sets the number of cases (default 3000), `FUZZ_SEED` the seed.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

use common::{Ending, entry_parts, resealed, run_limited};
use rand_pcg::Pcg64Mcg;
use rand_pcg::rand_core::RngCore;

const TIME_LIMIT: Duration = Duration::from_secs(10);

/// Which reader a case is aimed at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Reader {
    Dds,
    Ktx2,
    Exr,
    Bin,
    Shader,
    Manifest,
    Journal,
    HostileJournal,
    Config,
    Scene,
    /// A link planted under a name a build writes.
    Link,
    /// A FIFO in place of an input.
    Fifo,
    /// A hostile entry in a scene build's cache.
    HostileCache,
}

/// One damaged input and what must follow.
struct Case {
    reader: Reader,
    what: String,
    /// The file replaced, relative to the folder (or the config or scene file).
    file: String,
    bytes: Vec<u8>,
    /// `check` must report the folder: every byte of a table is covered by its SHA-256, and every
    /// manifest lie of these cases is about something the file states.
    check_must_fail: bool,
    /// Which plant, FIFO or hostile entry of [`LINKS`], [`FIFOS`] and [`HOSTILE_ENTRIES`].
    variant: usize,
}

/// Names a build writes, with what is planted there: a symbolic link to a file outside the
/// folder, one to a folder outside it, or a hard link to that file.
const LINKS: [(&str, &str); 11] = [
    (".tmlut.lock", "symlink to a file"),
    (".tmlut.lock", "hard link to a file"),
    ("gd.dds", "symlink to a file"),
    ("gd.dds", "hard link to a file"),
    ("manifest.json", "symlink to a file"),
    ("manifest.json", "hard link to a file"),
    ("maps", "symlink to a folder"),
    (".tmlut-staging-1", "symlink to a folder"),
    (".gd.dds.tmp-1", "symlink to a file"),
    (".manifest.json.tmp-1", "symlink to a file"),
    (".tmlut-commit.json", "symlink to a file"),
];

/// Inputs a FIFO takes the place of, each with the command that reads it.
const FIFOS: [&str; 9] =
    ["manifest.json", "gd.dds", "karis.exr", "config", "scene", "budgets", "form", ".tmlut-commit.json", "cache entry"];

/// Hostile edits of a cache a scene build reads.
const HOSTILE_ENTRIES: [&str; 8] = [
    "every value of an entry raised by 0.25, its hash line recomputed",
    "every value of an entry lowered by 0.05, its hash line recomputed",
    "an entry's contents under another entry's key",
    "an entry replaced by a symbolic link to a file outside",
    "links to a file outside planted under names of temporaries",
    "an entry's recorded inputs replaced, its hash line recomputed",
    "every value of a shard's entry raised by 0.25, its hash line recomputed, then merged",
    "a shard's entry under another entry's key, then merged",
];

/// How each run of a case ended, and whether a damaged folder passed.
#[derive(Default, Debug, Clone)]
struct Tally {
    cases: usize,
    runs: BTreeMap<Ending, usize>,
    /// A damaged table or a verifiable manifest lie that `check` or `inspect` accepted.
    data_lost: usize,
    examples: Vec<String>,
}

fn next(rng: &mut Pcg64Mcg, below: usize) -> usize {
    (rng.next_u64() % below.max(1) as u64) as usize
}

fn pick<'a, T>(rng: &mut Pcg64Mcg, items: &'a [T]) -> &'a T {
    &items[next(rng, items.len())]
}

const INTERESTING_U32: [u32; 10] = [0, 1, 2, 7, 0x7f, 0x8000, 0xffff, 0x7fff_ffff, 0x8000_0000, 0xffff_ffff];

/// An interesting or random 32-bit value.
fn lie_u32(rng: &mut Pcg64Mcg) -> u32 {
    if next(rng, 3) == 0 { rng.next_u64() as u32 } else { *pick(rng, &INTERESTING_U32) }
}

/// Truncation, bit flips, overwritten bytes or appended bytes: what a disk or a transfer does.
fn damage(rng: &mut Pcg64Mcg, original: &[u8]) -> (String, Vec<u8>) {
    let mut bytes = original.to_vec();
    let len = bytes.len();
    match next(rng, 4) {
        0 => {
            // Headers are where readers decide what to allocate: cut there more often.
            let cut = if next(rng, 2) == 0 { next(rng, len.min(256)) } else { next(rng, len) };
            bytes.truncate(cut);
            (format!("truncated to {cut} bytes"), bytes)
        }
        1 => {
            let flips = 1 + next(rng, 8);
            for _ in 0..flips {
                let bit = next(rng, len * 8);
                bytes[bit / 8] ^= 1 << (bit % 8);
            }
            (format!("{flips} bit(s) flipped"), bytes)
        }
        2 => {
            let count = 1 + next(rng, 4);
            for _ in 0..count {
                let at = if next(rng, 2) == 0 { next(rng, len.min(256)) } else { next(rng, len) };
                let random = rng.next_u64() as u8;
                bytes[at] = *pick(rng, &[0u8, 1, 0x10, 0x7f, 0x80, 0xff, random]);
            }
            (format!("{count} byte(s) overwritten"), bytes)
        }
        _ => {
            let extra = 1 + next(rng, 64);
            bytes.extend((0..extra).map(|_| rng.next_u64() as u8));
            (format!("{extra} byte(s) appended"), bytes)
        }
    }
}

/// A DDS header field set to a lie: sizes, flags, pitch, depth, mip count, formats, dimensions.
fn dds_lie(rng: &mut Pcg64Mcg, original: &[u8]) -> (String, Vec<u8>) {
    const FIELDS: [usize; 17] = [4, 8, 12, 16, 20, 24, 28, 76, 80, 84, 108, 112, 128, 132, 136, 140, 144];
    let mut bytes = original.to_vec();
    let offset = *pick(rng, &FIELDS);
    let value = lie_u32(rng);
    bytes[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
    (format!("header field at {offset} set to {value:#x}"), bytes)
}

/// A KTX2 lie: a header or level index field (format, type size, extents, layer, face and level
/// counts, supercompression, section offsets and lengths), a data format descriptor byte, or the
/// length of a key/value pair.
fn ktx2_lie(rng: &mut Pcg64Mcg, original: &[u8]) -> (String, Vec<u8>) {
    let mut bytes = original.to_vec();
    let word = |at: usize| u32::from_le_bytes(original[at..at + 4].try_into().unwrap()) as usize;
    let (dfd, kvd, kvd_len) = (word(48), word(56), word(60));
    let (offset, what) = match next(rng, 4) {
        0 | 1 => (12 + 4 * next(rng, (104 - 12) / 4), "header or level index field".to_string()),
        2 => {
            let at = dfd + next(rng, kvd - dfd);
            let value = *pick(rng, &[0u8, 1, 2, 0x7f, 0xff]);
            bytes[at] = value;
            return (format!("descriptor byte {} set to {value:#x}", at - dfd), bytes);
        }
        _ => {
            // The length field of one of the key/value pairs.
            let mut at = kvd;
            for _ in 0..next(rng, 6) {
                let next_at = (at + 4 + word(at)).next_multiple_of(4);
                if next_at >= kvd + kvd_len {
                    break;
                }
                at = next_at;
            }
            (at, "key/value pair length".to_string())
        }
    };
    let value = lie_u32(rng);
    bytes[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
    (format!("{what} at {offset} set to {value:#x}"), bytes)
}

/// An EXR header lie: a data or display window bound, the chunk count, an attribute's size, or any
/// aligned word of the header.
fn exr_lie(rng: &mut Pcg64Mcg, original: &[u8]) -> (String, Vec<u8>) {
    let mut bytes = original.to_vec();
    let find = |name: &[u8]| original.windows(name.len()).position(|w| w == name).map(|p| p + name.len());
    let targets: Vec<(usize, &str)> = [
        (&b"dataWindow\0box2i\0"[..], "dataWindow"),
        (&b"displayWindow\0box2i\0"[..], "displayWindow"),
        (&b"chunkCount\0int\0"[..], "chunkCount"),
        (&b"tmlut\0string\0"[..], "tmlut attribute"),
        (&b"channels\0chlist\0"[..], "channel list"),
    ]
    .iter()
    .filter_map(|(marker, name)| find(marker).map(|at| (at, *name)))
    .collect();
    let value = lie_u32(rng);
    let (offset, what) = match next(rng, 3) {
        // The attribute's size word, or a word of its value.
        0 | 1 if !targets.is_empty() => {
            let (at, name) = *pick(rng, &targets);
            let word = next(rng, 5);
            (at + 4 * word, format!("{name} word {word}"))
        }
        _ => {
            let at = 8 + 4 * next(rng, (original.len().min(1024) - 12) / 4);
            (at, "header word".to_string())
        }
    };
    if offset + 4 <= bytes.len() {
        bytes[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
    }
    (format!("{what} at {offset} set to {value:#x}"), bytes)
}

/// A `.bin` header lie: a size (int32) or a range end (float32).
fn bin_lie(rng: &mut Pcg64Mcg, original: &[u8], axes: usize) -> (String, Vec<u8>) {
    let mut bytes = original.to_vec();
    let word = next(rng, 3 * axes);
    let value = if word < axes {
        lie_u32(rng)
    } else {
        pick(rng, &[f32::NAN, f32::INFINITY, -1.0, 0.0, 1e38, 4.0, f32::MIN_POSITIVE]).to_bits()
    };
    bytes[4 * word..4 * word + 4].copy_from_slice(&value.to_le_bytes());
    (format!("header word {word} of {} set to {value:#x}", 3 * axes), bytes)
}

/// A manifest that lies about a file in a way the file can refute, or names a path outside the
/// folder. Returns the lie and the file it is about.
fn manifest_lie(rng: &mut Pcg64Mcg, manifest: &serde_json::Value) -> (String, Vec<u8>, String) {
    use serde_json::json;
    let mut m = manifest.clone();
    let files: Vec<String> = m["files"].as_object().unwrap().keys().cloned().collect();
    let file = pick(rng, &files).clone();
    let entry = &mut m["files"][&file];
    let axes = entry["axes"].as_array().unwrap().len();
    let axis = next(rng, axes);
    let stores_axes = !file.ends_with(".dds");
    let big = *pick(rng, &[0u64, 1, 3, 1 << 32, 1 << 40, u64::MAX]);
    let mut about = file.clone();
    let what = match next(rng, 14) {
        0 => {
            entry["axes"][axis]["count"] = json!(big);
            format!("axis {axis} count {big}")
        }
        1 if stores_axes => {
            let a = &mut entry["axes"][axis];
            let (start, end) = (a["start"].clone(), a["end"].clone());
            a["start"] = end;
            a["end"] = start;
            format!("axis {axis} reversed")
        }
        2 => {
            entry["value_range"][next(rng, 2)] = json!(*pick(rng, &[-1.0, 0.5, 2.0, 1e30]));
            "value range".into()
        }
        3 => {
            entry["nan_count"] = json!(1 + next(rng, 1000));
            "NaN count".into()
        }
        4 => {
            entry["bytes"] = json!(big);
            format!("bytes {big}")
        }
        5 => {
            entry["sha256"] = json!(format!("{:064x}", rng.next_u64()));
            "SHA-256".into()
        }
        6 => {
            entry["channels"].as_array_mut().unwrap().pop();
            "one channel fewer".into()
        }
        7 => {
            let extra = json!({"name": "extra", "meaning": "a lie"});
            entry["channels"].as_array_mut().unwrap().push(extra);
            "one channel more".into()
        }
        8 => {
            entry["axes"].as_array_mut().unwrap().pop();
            "one axis fewer".into()
        }
        9 => {
            let first = entry["axes"][0].clone();
            entry["axes"].as_array_mut().unwrap().push(first);
            "one axis more".into()
        }
        10 if file.ends_with(".dds") => {
            let other: Vec<&str> = ["R32_FLOAT", "R16G16_FLOAT", "R16G16B16A16_FLOAT", "BC7_UNORM"]
                .into_iter()
                .filter(|f| entry["dxgi_format"] != *f)
                .collect();
            entry["dxgi_format"] = json!(pick(rng, &other));
            "DXGI format".into()
        }
        10 if file.ends_with(".ktx2") => {
            let other: Vec<&str> = ["R32_SFLOAT", "R16G16_SFLOAT", "R16G16B16A16_SFLOAT", "BC7_UNORM_BLOCK"]
                .into_iter()
                .filter(|f| entry["vk_format"] != *f)
                .collect();
            entry["vk_format"] = json!(pick(rng, &other));
            "Vulkan format".into()
        }
        11 => {
            let name = pick(rng, &["/etc/hostname", "../../x", "../luts/gd.bin", "a/b.dds", "", "..", "ghost.dds"]);
            let moved = m["files"].as_object_mut().unwrap().remove(&file).unwrap();
            m["files"][*name] = moved;
            about = name.to_string();
            format!("renamed to {name:?}")
        }
        12 if entry.get("packing").is_some() => {
            let shader = &mut entry["packing"]["shaders"][next(rng, 2)];
            if next(rng, 2) == 0 {
                shader["file"] = json!(pick(rng, &["../../etc/passwd", "/etc/hostname", "missing.hlsl"]));
            } else {
                shader["sha256"] = json!(format!("{:064x}", rng.next_u64()));
            }
            "packed texture's shader".into()
        }
        _ => {
            entry["format"] = json!(pick(rng, &["dds", "exr", "bin", "ktx2"]));
            // A format the file has: not a lie.
            let stated = entry["format"].as_str().unwrap();
            if file.ends_with(&format!(".{stated}")) {
                entry["nan_count"] = json!(7);
            }
            "format".into()
        }
    };
    (format!("manifest: {about}: {what}"), serde_json::to_vec_pretty(&m).unwrap(), about)
}

/// Damage to the manifest's text itself: truncation, flipped bits, nesting no parser should follow.
fn manifest_text_damage(rng: &mut Pcg64Mcg, original: &[u8]) -> (String, Vec<u8>) {
    if next(rng, 8) == 0 {
        let depth = 1 + next(rng, 100_000);
        let text = format!("{{\"generator\": \"x\", \"files\": {}{}}}", "[".repeat(depth), "]".repeat(depth));
        return (format!("nested {depth} deep"), text.into_bytes());
    }
    damage(rng, original)
}

/// A number in a TOML text replaced by an extreme one, or the text damaged.
fn toml_damage(rng: &mut Pcg64Mcg, original: &str) -> (String, Vec<u8>) {
    let numbers: Vec<(usize, usize)> = {
        let bytes = original.as_bytes();
        let mut spans = Vec::new();
        let mut k = 0;
        while k < bytes.len() {
            if bytes[k].is_ascii_digit() && (k == 0 || !bytes[k - 1].is_ascii_alphanumeric() && bytes[k - 1] != b'_') {
                let start = k;
                while k < bytes.len() && (bytes[k].is_ascii_digit() || bytes[k] == b'.' || bytes[k] == b'e') {
                    k += 1;
                }
                spans.push((start, k));
            }
            k += 1;
        }
        spans
    };
    if next(rng, 3) != 0 && !numbers.is_empty() {
        let (start, end) = *pick(rng, &numbers);
        let lie = *pick(
            rng,
            &[
                "0",
                "-1",
                "1e300",
                "-1e300",
                "nan",
                "inf",
                "4294967296",
                "18446744073709551615",
                "1e-320",
                "65",
                "[1, 2, 3]",
                "\"x\"",
            ],
        );
        let text = format!("{}{lie}{}", &original[..start], &original[end..]);
        return (format!("`{}` replaced by `{lie}`", &original[start..end]), text.into_bytes());
    }
    damage(rng, original.as_bytes())
}

/// Every case, from `seed`: tables of every format most, then the manifest, the commit journal,
/// shaders, configurations and scenes.
fn cases(seed: u64, count: usize, folder: &Path, config: &str, scene: &str) -> Vec<Case> {
    // Odd, as the generator needs, and distinct for every seed (`seed | 1` made 2 and 3 one stream).
    let mut rng = Pcg64Mcg::new((seed as u128) << 1 | 1);
    let read = |name: &str| std::fs::read(folder.join(name)).unwrap();
    let manifest_bytes = read("manifest.json");
    let manifest: serde_json::Value = serde_json::from_slice(&manifest_bytes).unwrap();
    let tables = [
        "karis.dds",
        "belcour.dds",
        "fgd_lossless.dds",
        "gd.dds",
        "tir.dds",
        "karis.ktx2",
        "belcour.ktx2",
        "fgd_lossless.ktx2",
        "gd.ktx2",
        "tir.ktx2",
        "karis.exr",
        "belcour.exr",
        "fgd.exr",
        "gd.exr",
        "tir.exr",
        "fgd.bin",
        "gd.bin",
        "tir.bin",
    ];
    let shaders = ["fgd_lossless.hlsl", "fgd_lossless.wgsl", "tir_fit.hlsl", "tir_fit.wgsl"];
    let mut all = Vec::with_capacity(count);
    while all.len() < count {
        let roll = next(&mut rng, 100);
        let case = if roll >= 88 {
            let (reader, variant, what) = match roll {
                88..=91 => {
                    let variant = next(&mut rng, LINKS.len());
                    (Reader::Link, variant, format!("{} at {}", LINKS[variant].1, LINKS[variant].0))
                }
                92..=95 => {
                    let variant = next(&mut rng, FIFOS.len());
                    (Reader::Fifo, variant, format!("a FIFO as {}", FIFOS[variant]))
                }
                _ => {
                    let variant = next(&mut rng, HOSTILE_ENTRIES.len());
                    (Reader::HostileCache, variant, HOSTILE_ENTRIES[variant].to_string())
                }
            };
            Case { reader, what, file: String::new(), check_must_fail: false, bytes: Vec::new(), variant }
        } else if roll < 52 {
            let file = *pick(&mut rng, &tables);
            let original = read(file);
            let (reader, (what, bytes)) = match (file.rsplit('.').next().unwrap(), next(&mut rng, 2)) {
                ("dds", 0) => (Reader::Dds, dds_lie(&mut rng, &original)),
                ("ktx2", 0) => (Reader::Ktx2, ktx2_lie(&mut rng, &original)),
                ("exr", 0) => (Reader::Exr, exr_lie(&mut rng, &original)),
                ("bin", 0) => {
                    let axes = manifest["files"][file]["axes"].as_array().unwrap().len();
                    (Reader::Bin, bin_lie(&mut rng, &original, axes))
                }
                ("dds", _) => (Reader::Dds, damage(&mut rng, &original)),
                ("ktx2", _) => (Reader::Ktx2, damage(&mut rng, &original)),
                ("exr", _) => (Reader::Exr, damage(&mut rng, &original)),
                _ => (Reader::Bin, damage(&mut rng, &original)),
            };
            Case { reader, what, file: file.into(), check_must_fail: bytes != original, bytes, variant: 0 }
        } else if roll < 68 {
            if next(&mut rng, 3) == 0 {
                let (what, bytes) = manifest_text_damage(&mut rng, &manifest_bytes);
                Case {
                    reader: Reader::Manifest,
                    what,
                    file: "manifest.json".into(),
                    check_must_fail: false,
                    bytes,
                    variant: 0,
                }
            } else {
                let (what, bytes, _) = manifest_lie(&mut rng, &manifest);
                Case {
                    reader: Reader::Manifest,
                    what,
                    file: "manifest.json".into(),
                    check_must_fail: true,
                    bytes,
                    variant: 0,
                }
            }
        } else if roll < 70 {
            let (what, bytes) = hostile_journal(&mut rng);
            Case {
                reader: Reader::HostileJournal,
                what,
                file: ".tmlut-commit.json".into(),
                check_must_fail: true,
                bytes,
                variant: 0,
            }
        } else if roll < 71 {
            let journal =
                serde_json::json!({"staging": ".tmlut-staging-1", "moves": [{"staged": "x", "destination": "gd.bin"}]});
            let (what, bytes) = damage(&mut rng, &serde_json::to_vec(&journal).unwrap());
            Case {
                reader: Reader::Journal,
                what,
                file: ".tmlut-commit.json".into(),
                check_must_fail: true,
                bytes,
                variant: 0,
            }
        } else if roll < 75 {
            let file = *pick(&mut rng, &shaders);
            let original = read(file);
            let (what, bytes) = damage(&mut rng, &original);
            Case {
                reader: Reader::Shader,
                what,
                file: file.into(),
                check_must_fail: bytes != original,
                bytes,
                variant: 0,
            }
        } else if roll < 82 {
            let (what, bytes) = toml_damage(&mut rng, config);
            Case { reader: Reader::Config, what, file: "config.toml".into(), check_must_fail: false, bytes, variant: 0 }
        } else if next(&mut rng, 3) == 0 {
            let (what, bytes) = hostile_names(&mut rng, scene);
            Case { reader: Reader::Scene, what, file: "scene.toml".into(), check_must_fail: false, bytes, variant: 0 }
        } else {
            let (what, bytes) = toml_damage(&mut rng, scene);
            Case { reader: Reader::Scene, what, file: "scene.toml".into(), check_must_fail: false, bytes, variant: 0 }
        };
        all.push(case);
    }
    all
}

/// The scene with its own name or a material's replaced by one that names a path, collides with
/// another as a file name, is empty, too long, or not text a file system takes.
fn hostile_names(rng: &mut Pcg64Mcg, scene: &str) -> (String, Vec<u8>) {
    let long = "n".repeat(300);
    let names = [
        "../victim",
        "/etc/passwd",
        "a/b",
        "",
        ".",
        "..",
        "con",
        "table0",
        "finite-or",
        "Worn-Gold",
        "worn gold",
        "glazed-ceramic",
        &long,
        r"tab\there",
        r"\u0000",
        "é⁄∕",
    ];
    let name = *pick(rng, &names);
    let which = next(rng, 3);
    let mut seen = 0;
    let text: Vec<String> = scene
        .lines()
        .map(|line| {
            if line.starts_with("name = ") {
                seen += 1;
                if seen == which + 1 {
                    return format!("name = \"{name}\"");
                }
            }
            line.to_string()
        })
        .collect();
    (format!("name {which} = {name:?}"), (text.join("\n") + "\n").into_bytes())
}

/// Stands for the absolute path of a file outside the folder, filled in where the case runs.
const VICTIM: &str = "{VICTIM}";

/// A commit journal that names a path outside the folder (absolute, climbing out with `..`, or
/// through a folder that is not there) as a staged file, a destination, a removal or the staging
/// folder, the rest of it well formed.
fn hostile_journal(rng: &mut Pcg64Mcg) -> (String, Vec<u8>) {
    let paths = [VICTIM, "../victim.txt", "./../victim.txt", "a/../../victim.txt", "..", "/", "../luts/../victim.txt"];
    let path = *pick(rng, &paths);
    let benign_move = serde_json::json!({"staged": "gd.dds", "destination": "gd.dds"});
    let (place, journal) = match next(rng, 4) {
        0 => ("removal", serde_json::json!({"staging": ".tmlut-staging-1", "moves": [], "removals": [path]})),
        1 => (
            "move destination",
            serde_json::json!({"staging": ".tmlut-staging-1", "moves": [{"staged": "gd.dds", "destination": path}]}),
        ),
        2 => (
            "staged file",
            serde_json::json!({"staging": ".tmlut-staging-1", "moves": [{"staged": path, "destination": "gd.dds"}]}),
        ),
        _ => ("staging folder", serde_json::json!({"staging": path, "moves": [benign_move], "removals": ["gd.dds"]})),
    };
    (format!("{place} {path}"), serde_json::to_vec(&journal).unwrap())
}

/// What the cases of the cache share: a small scene, a cache its build filled, and the files of
/// that build (the cache's honest output).
struct SceneCache {
    scene: PathBuf,
    config: PathBuf,
    cache: PathBuf,
    clean: PathBuf,
    /// The scene built as two shards (`--shard 1/2`, `2/2`), for `tmlut merge`.
    shards: [PathBuf; 2],
}

/// The bytes a run must leave alone: `work/victim.txt` and the folder `work/victim`, created
/// anew for each case.
fn victims(work: &Path) -> (PathBuf, PathBuf) {
    let (file, folder) = (work.join("victim.txt"), work.join("victim"));
    std::fs::write(&file, "not tmlut's").unwrap();
    let _ = std::fs::remove_dir_all(&folder);
    std::fs::create_dir(&folder).unwrap();
    std::fs::write(folder.join("kept"), "not tmlut's").unwrap();
    (file, folder)
}

/// Whether a run changed either victim.
fn victims_touched(file: &Path, folder: &Path) -> bool {
    std::fs::read(file).ok().as_deref() != Some(b"not tmlut's".as_slice())
        || snapshot(folder) != [("kept".into(), b"not tmlut's".to_vec())]
}

/// Plant `what` at `at`: a symbolic link to the victim file or folder, or a hard link to the file.
fn plant(at: &Path, what: &str, file: &Path, folder: &Path) {
    let _ = std::fs::remove_file(at);
    let _ = std::fs::remove_dir_all(at);
    match what {
        "symlink to a file" => std::os::unix::fs::symlink(file, at).unwrap(),
        "symlink to a folder" => std::os::unix::fs::symlink(folder, at).unwrap(),
        _ => std::fs::hard_link(file, at).unwrap(),
    }
}

fn mkfifo(path: &Path) {
    let _ = std::fs::remove_file(path);
    let made = std::process::Command::new("mkfifo").arg(path).status().unwrap();
    assert!(made.success(), "mkfifo {}", path.display());
}

/// The slice entries of a cache folder, in name order.
fn slice_entries(cache: &Path) -> Vec<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(cache)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "slice"))
        .collect();
    entries.sort();
    entries
}

/// Run one case in `work` (a copy of the folder, with `config.toml` and `scene.toml` beside it)
/// and put the file back. Returns each run's ending and whether a damaged folder was accepted.
fn run_case(
    case: &Case,
    work: &Path,
    folder: &Path,
    built: &Path,
    budgets: &Path,
    scene_cache: &SceneCache,
) -> (Vec<common::Run>, bool) {
    let folder_arg = folder.to_str().unwrap();
    let config = work.join("config.toml");
    let config_arg = config.to_str().unwrap();
    match case.reader {
        Reader::Link => {
            let (file, outside) = victims(work);
            let (name, what) = LINKS[case.variant];
            plant(&folder.join(name), what, &file, &outside);
            let mut args = vec!["build", "-q", "--only", "gd", "--config", config_arg, "--out", folder_arg];
            if name == "maps" {
                args.push("--error-maps");
            }
            let build = run_limited(&args, TIME_LIMIT);
            let lost = victims_touched(&file, &outside);
            std::fs::remove_dir_all(folder).unwrap();
            copy_folder(built, folder);
            (vec![build], lost)
        }
        Reader::Fifo => {
            let target = FIFOS[case.variant];
            let fifo = match target {
                "config" | "scene" | "budgets" | "form" => work.join(format!("fifo-{target}.toml")),
                "cache entry" => work.join("cache"),
                name => folder.join(name),
            };
            let fifo_arg = fifo.to_str().unwrap().to_string();
            if target != "cache entry" {
                mkfifo(&fifo);
            }
            let runs = match target {
                "config" => vec![run_limited(
                    &["build", "-q", "--only", "gd", "--config", &fifo_arg, "--out", folder_arg],
                    TIME_LIMIT,
                )],
                "scene" => vec![run_limited(&["plan", &fifo_arg, "--config", config_arg], TIME_LIMIT)],
                "budgets" => vec![run_limited(&["check", folder_arg, "--budgets", &fifo_arg], TIME_LIMIT)],
                "form" => {
                    let table = folder.join("karis.exr");
                    let out = work.join("fit-out");
                    vec![run_limited(
                        &[
                            "fit",
                            "--form",
                            &fifo_arg,
                            "--table",
                            table.to_str().unwrap(),
                            "--out",
                            out.to_str().unwrap(),
                        ],
                        TIME_LIMIT,
                    )]
                }
                "cache entry" => {
                    let _ = std::fs::remove_dir_all(&fifo);
                    copy_folder(&scene_cache.cache, &fifo);
                    mkfifo(&slice_entries(&fifo)[0]);
                    let out = work.join("scene-out");
                    let (scene, config) = (scene_cache.scene.to_str().unwrap(), scene_cache.config.to_str().unwrap());
                    vec![run_limited(
                        &[
                            "build",
                            "-q",
                            "--scene",
                            scene,
                            "--config",
                            config,
                            "--cache",
                            &fifo_arg,
                            "--out",
                            out.to_str().unwrap(),
                        ],
                        TIME_LIMIT,
                    )]
                }
                ".tmlut-commit.json" => {
                    vec![run_limited(
                        &["build", "-q", "--only", "gd", "--config", config_arg, "--out", folder_arg],
                        TIME_LIMIT,
                    )]
                }
                _ => {
                    let inspected = if target == "manifest.json" { folder.join("gd.dds") } else { fifo.clone() };
                    vec![
                        run_limited(&["check", folder_arg, "--budgets", budgets.to_str().unwrap()], TIME_LIMIT),
                        run_limited(&["inspect", inspected.to_str().unwrap()], TIME_LIMIT),
                    ]
                }
            };
            let _ = std::fs::remove_file(work.join(format!("fifo-{target}.toml")));
            std::fs::remove_dir_all(folder).unwrap();
            copy_folder(built, folder);
            (runs, false)
        }
        Reader::HostileCache => {
            let (file, outside) = victims(work);
            let merging = case.variant >= 6;
            let cache = work.join("cache");
            let _ = std::fs::remove_dir_all(&cache);
            copy_folder(if merging { &scene_cache.shards[0] } else { &scene_cache.cache }, &cache);
            // Without the whole build's record, the build reads the slices' entries one by one.
            for record in std::fs::read_dir(&cache).unwrap().flatten().map(|e| e.path()) {
                if record.extension().is_some_and(|e| e == "build") {
                    std::fs::remove_file(record).unwrap();
                }
            }
            let entries = slice_entries(&cache);
            let first = &entries[0];
            let (line, mut body) = entry_parts(&std::fs::read(first).unwrap());
            match case.variant {
                0 | 1 | 6 => {
                    let by = if case.variant == 1 { -0.05 } else { 0.25 };
                    for v in body["values"].as_array_mut().unwrap() {
                        *v = serde_json::json!(v.as_f64().unwrap() + by);
                    }
                    std::fs::write(first, resealed(&line, &body)).unwrap();
                }
                2 | 7 => std::fs::copy(&entries[1], first).map(|_| ()).unwrap(),
                3 => plant(first, "symlink to a file", &file, &outside),
                4 => {
                    for (k, entry) in entries.iter().enumerate() {
                        let name = entry.file_name().unwrap().to_str().unwrap();
                        plant(&cache.join(format!(".{name}.tmp-{k}")), "symlink to a file", &file, &outside);
                    }
                }
                _ => {
                    let (_, other) = entry_parts(&std::fs::read(&entries[1]).unwrap());
                    body["inputs"] = other["inputs"].clone();
                    std::fs::write(first, resealed(&line, &body)).unwrap();
                }
            }
            let out = work.join("scene-out");
            let _ = std::fs::remove_dir_all(&out);
            let (scene, config) = (scene_cache.scene.to_str().unwrap(), scene_cache.config.to_str().unwrap());
            let (cache, out_arg) = (cache.to_str().unwrap(), out.to_str().unwrap());
            let args: Vec<&str> = if merging {
                let second = scene_cache.shards[1].to_str().unwrap();
                vec!["merge", "-q", "--scene", scene, "--config", config, "--out", out_arg, cache, second]
            } else {
                vec!["build", "-q", "--scene", scene, "--config", config, "--cache", cache, "--out", out_arg]
            };
            let build = run_limited(&args, TIME_LIMIT);
            // Every file but the manifest (its wall times and cache notes) as a build without the
            // cache wrote it.
            let tables = |dir: &Path| -> Vec<_> {
                snapshot(dir).into_iter().filter(|(name, _)| name != "manifest.json").collect()
            };
            let poisoned = build.ending == Ending::Success && tables(&out) != tables(&scene_cache.clean);
            (vec![build], poisoned || victims_touched(&file, &outside))
        }
        Reader::HostileJournal => {
            // A build completes a journal before it builds: it must refuse this one and touch
            // nothing outside the folder (nor, refusing, inside it).
            let victim = work.join("victim.txt");
            std::fs::write(&victim, "not tmlut's").unwrap();
            let text = String::from_utf8(case.bytes.clone()).unwrap().replace(VICTIM, victim.to_str().unwrap());
            std::fs::write(folder.join(&case.file), text).unwrap();
            let before = snapshot(folder);
            let config = work.join("config.toml");
            let build = run_limited(
                &["build", "-q", "--only", "gd", "--config", config.to_str().unwrap(), "--out", folder_arg],
                TIME_LIMIT,
            );
            let lost = std::fs::read(&victim).ok().as_deref() != Some(b"not tmlut's".as_slice())
                || build.ending == Ending::Success
                || snapshot(folder) != before;
            // Back to the built folder for the next case.
            std::fs::remove_dir_all(folder).unwrap();
            copy_folder(built, folder);
            (vec![build], lost)
        }
        Reader::Config | Reader::Scene => {
            let path = work.join(&case.file);
            let original = std::fs::read(&path).unwrap();
            std::fs::write(&path, &case.bytes).unwrap();
            let scene = work.join("scene.toml");
            let config = work.join("config.toml");
            let run = run_limited(&["plan", scene.to_str().unwrap(), "--config", config.to_str().unwrap()], TIME_LIMIT);
            std::fs::write(&path, original).unwrap();
            (vec![run], false)
        }
        _ => {
            let path = folder.join(&case.file);
            let original = std::fs::read(&path).ok();
            std::fs::write(&path, &case.bytes).unwrap();
            let check = run_limited(&["check", folder_arg, "--budgets", budgets.to_str().unwrap()], TIME_LIMIT);
            // `inspect` reads a table with the manifest beside it: the damaged one, or one that
            // the manifest describes.
            let inspected = if [".dds", ".ktx2", ".exr", ".bin"].iter().any(|e| case.file.contains(e)) {
                case.file.clone()
            } else {
                "karis.exr".into()
            };
            let inspect = run_limited(&["inspect", folder.join(&inspected).to_str().unwrap()], TIME_LIMIT);
            match original {
                Some(bytes) => std::fs::write(&path, bytes).unwrap(),
                None => std::fs::remove_file(&path).unwrap(),
            }
            // A damaged table or shader must fail `check`; a damaged table must fail `inspect` too.
            let damaged_table =
                matches!(case.reader, Reader::Dds | Reader::Ktx2 | Reader::Exr | Reader::Bin) && case.check_must_fail;
            let lost = (case.check_must_fail && check.ending == Ending::Success)
                || (damaged_table && inspect.ending == Ending::Success);
            (vec![check, inspect], lost)
        }
    }
}

/// One row of the report's table.
fn row(reader: &str, tally: &Tally) -> String {
    let n = |e| tally.runs.get(&e).copied().unwrap_or(0);
    format!(
        "| {reader} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
        tally.cases,
        tally.runs.values().sum::<usize>(),
        n(Ending::Success),
        n(Ending::CleanError),
        n(Ending::Panic),
        n(Ending::Abort),
        n(Ending::Hang),
        tally.data_lost
    )
}

/// Every file of a folder (not its subfolders) with its bytes, sorted by name.
fn snapshot(dir: &Path) -> Vec<(std::ffi::OsString, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| (e.file_name(), std::fs::read(e.path()).unwrap_or_default()))
        .collect();
    files.sort();
    files
}

fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
    }
}

#[test]
fn every_reader_survives_thousands_of_damaged_inputs() {
    let seed: u64 = std::env::var("FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(2021);
    let count: usize = std::env::var("FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(3000);
    let dir = tempfile::tempdir().unwrap();
    let config = common::small_set_in_every_format();
    let built = common::build_config(dir.path(), &config, &[]);
    let scene = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/luts/scenes/textured.toml")).unwrap();
    let cases = cases(seed, count, &built, &config, &scene);
    let budgets = dir.path().join("budgets.toml");
    std::fs::write(&budgets, "").unwrap();
    // A one-material scene built twice from the small set: into a cache, and without one (what
    // a build reading a hostile cache must still write).
    let scene_config = dir.path().join("scene-config.toml");
    std::fs::write(&scene_config, common::SMALL_SET).unwrap();
    let scene_cache = SceneCache {
        scene: PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/luts/scenes/copper-pot.toml")),
        config: scene_config,
        cache: dir.path().join("scene-cache"),
        clean: dir.path().join("scene-clean"),
        shards: [dir.path().join("shard-1"), dir.path().join("shard-2")],
    };
    for (k, shard) in scene_cache.shards.iter().enumerate() {
        let part = format!("{}/2", k + 1);
        let mut args = vec!["build", "-q", "--scene", scene_cache.scene.to_str().unwrap(), "--shard", &part];
        args.extend(["--config", scene_cache.config.to_str().unwrap(), "--cache", shard.to_str().unwrap()]);
        let run = run_limited(&args, TIME_LIMIT);
        assert_eq!(run.ending, Ending::Success, "{}", run.stderr);
    }
    for (out, cache) in [(dir.path().join("scene-cached"), Some(&scene_cache.cache)), (scene_cache.clean.clone(), None)]
    {
        let mut args = vec!["build", "-q", "--scene", scene_cache.scene.to_str().unwrap()];
        args.extend(["--config", scene_cache.config.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        if let Some(cache) = cache {
            args.extend(["--cache", cache.to_str().unwrap()]);
        }
        let run = run_limited(&args, TIME_LIMIT);
        assert_eq!(run.ending, Ending::Success, "{}", run.stderr);
    }
    assert!(slice_entries(&scene_cache.cache).len() >= 2);

    // Two workers, each with its own copy of the folder; cases are dealt out in order.
    let workers = 2;
    let tallies: Mutex<BTreeMap<Reader, Tally>> = Mutex::new(BTreeMap::new());
    std::thread::scope(|scope| {
        for worker in 0..workers {
            let (cases, tallies, budgets, built, scene, config) = (&cases, &tallies, &budgets, &built, &scene, &config);
            let scene_cache = &scene_cache;
            let work: PathBuf = dir.path().join(format!("worker{worker}"));
            scope.spawn(move || {
                let folder = work.join("luts");
                copy_folder(built, &folder);
                std::fs::write(work.join("config.toml"), config).unwrap();
                std::fs::write(work.join("scene.toml"), scene).unwrap();
                for case in cases.iter().skip(worker).step_by(workers) {
                    let (runs, lost) = run_case(case, &work, &folder, built, budgets, scene_cache);
                    let mut tallies = tallies.lock().unwrap();
                    let tally = tallies.entry(case.reader).or_default();
                    tally.cases += 1;
                    tally.data_lost += usize::from(lost);
                    for run in &runs {
                        *tally.runs.entry(run.ending).or_default() += 1;
                        let bad = matches!(run.ending, Ending::Panic | Ending::Abort | Ending::Hang);
                        if (bad || lost) && tally.examples.len() < 5 {
                            tally.examples.push(format!(
                                "{} ({}): {:?}: {}",
                                case.file,
                                case.what,
                                run.ending,
                                run.stderr.lines().next().unwrap_or("")
                            ));
                        }
                    }
                }
            });
        }
    });

    let tallies = tallies.into_inner().unwrap();
    let mut report = String::from(
        "| reader | cases | runs | exit 0 | clean errors | panics | aborts | hangs | data lost |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    let mut total = Tally::default();
    for (reader, tally) in &tallies {
        report.push_str(&row(&format!("{reader:?}"), tally));
        total.cases += tally.cases;
        total.data_lost += tally.data_lost;
        for (ending, k) in &tally.runs {
            *total.runs.entry(*ending).or_default() += k;
        }
        total.examples.extend(tally.examples.iter().cloned());
    }
    report.push_str(&row("all", &total));
    let n = |e| total.runs.get(&e).copied().unwrap_or(0);
    eprintln!("fuzz, seed {seed}:\n{report}");
    assert!(total.cases >= 2000.min(count), "{report}");
    assert!(
        n(Ending::Panic) + n(Ending::Abort) + n(Ending::Hang) + total.data_lost == 0,
        "{report}\n{}",
        total.examples.join("\n")
    );
}
