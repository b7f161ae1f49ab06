//! Structure-aware mutations: of text formats by number, word and line (OBJ/MTL, AFF, TOML),
//! of JSON by value (glTF), of binary formats by aligned field (GLB, ray and hit files), and
//! of any file by bytes (flips, inserts, deletes, copies, splices with other seeds).
//!
//! The values put in are the ones loaders get wrong: zero, negative and enormous counts,
//! NaN and infinities, numbers that overflow u32/i32/f32, paths to devices, parents and
//! absolute files, malformed escapes, and lines repeated thousands of times.

/// A small deterministic generator (splitmix64): the same seed gives the same run.
#[derive(Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9e37_79b9_7f4a_7c15)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// True with probability 1/n.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    /// One of `items`.
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// How a file is mutated beyond its bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Numbers, words and lines.
    Text,
    /// JSON values (falls back to text when the JSON no longer parses).
    Json,
    /// Aligned 4- and 8-byte fields.
    Binary,
}

/// Numbers that break counts, indices and arithmetic.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "3",
    "-2",
    "7",
    "255",
    "256",
    "65535",
    "65536",
    "1000000",
    "2147483647",
    "2147483648",
    "-2147483649",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999",
    "1e9",
    "1e18",
    "1e38",
    "3.5e38",
    "-3.5e38",
    "1e308",
    "1e400",
    "-1e400",
    "1e-45",
    "1e-300",
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "Infinity",
    "0.5",
    "-0.5",
    "1.5",
    "0x10",
    "1e",
    "--1",
    "1..2",
    ".",
];

/// Words: paths, escapes, keywords out of place, and the empty and the huge.
const WORDS: &[&str] = &[
    "/dev/zero",
    "/dev/urandom",
    "/proc/self/mem",
    "/etc/passwd",
    "../x.obj",
    "../../../../etc/passwd",
    "file:///etc/passwd",
    "scenes:../../../etc/passwd",
    "%FF%FE",
    "%",
    "data:application/octet-stream;base64,@@@",
    "inc.aff",
    "scene.mtl",
    "scene.bin",
    "tri.obj",
    ".",
    "",
    "{",
    "}",
    "#",
    "f",
    "v",
    "vn",
    "vt",
    "usemtl",
    "mtllib",
    "newmtl",
    "g",
    "o",
    "i",
    "x",
    "xs",
    "k",
    "tpa",
    "\u{feff}",
    "\u{0}",
    "é",
    "\\",
    "\"",
    "[",
    "]",
    "=",
];

/// Integers for binary fields.
const INTS: &[u64] = &[
    0,
    1,
    2,
    3,
    0x7f,
    0xff,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_fffe,
    0xffff_ffff,
    0x1_0000_0000,
    0x7fff_ffff_ffff_ffff,
    u64::MAX,
];

/// f32 bit patterns for binary fields: NaN, infinities, zero signs, extremes, subnormals.
const FLOATS: &[u32] = &[
    0x7fc0_0000,
    0xffc0_0000,
    0x7f80_0000,
    0xff80_0000,
    0x0000_0000,
    0x8000_0000,
    0x7f7f_ffff,
    0xff7f_ffff,
    0x0000_0001,
    0x3f80_0000,
    0xbf80_0000,
];

/// Mutate `data` (a file of `kind`) 1–4 times; `others` are other seeds of the same file to
/// splice from.
pub fn mutate(rng: &mut Rng, data: &mut Vec<u8>, kind: Kind, others: &[&[u8]]) {
    let n = 1 + rng.below(4);
    for _ in 0..n {
        match (kind, rng.below(10)) {
            (_, 0 | 1) => bytes(rng, data, others),
            (Kind::Text, _) => text(rng, data, others),
            (Kind::Json, _) => {
                if !json(rng, data) {
                    text(rng, data, others)
                }
            }
            (Kind::Binary, _) => binary(rng, data),
        }
    }
    // Keep inputs small: the loaders' cost per byte is not what is being searched for.
    data.truncate(256 << 10);
}

fn bytes(rng: &mut Rng, d: &mut Vec<u8>, others: &[&[u8]]) {
    let len = d.len();
    match rng.below(7) {
        0 if len > 0 => {
            let i = rng.below(len);
            d[i] ^= 1 << rng.below(8);
        }
        1 if len > 0 => {
            let i = rng.below(len);
            d[i] = rng.next_u64() as u8;
        }
        2 => {
            let i = rng.below(len + 1);
            let k = 1 + rng.below(8);
            let ins: Vec<u8> = (0..k).map(|_| rng.next_u64() as u8).collect();
            d.splice(i..i, ins);
        }
        3 if len > 0 => {
            let i = rng.below(len);
            let k = 1 + rng.below((len - i).min(64));
            d.drain(i..i + k);
        }
        4 if len > 0 => {
            // Copy a range elsewhere (repeats structure).
            let i = rng.below(len);
            let k = 1 + rng.below((len - i).min(256));
            let chunk = d[i..i + k].to_vec();
            let at = rng.below(len + 1);
            d.splice(at..at, chunk);
        }
        5 if !others.is_empty() => {
            // Splice: our head, another seed's tail.
            let o = *rng.pick(others);
            let cut = rng.below(d.len() + 1);
            let from = rng.below(o.len() + 1);
            d.truncate(cut);
            d.extend_from_slice(&o[from..]);
        }
        _ => {
            let cut = rng.below(len + 1);
            d.truncate(cut);
        }
    }
}

/// Spans of number-like tokens (a run of digits, signs, dots and exponents with a digit).
fn number_spans(d: &[u8]) -> Vec<(usize, usize)> {
    let num = |c: u8| c.is_ascii_digit() || matches!(c, b'-' | b'+' | b'.' | b'e' | b'E');
    let mut out = Vec::new();
    let mut i = 0;
    while i < d.len() {
        if num(d[i]) && (i == 0 || !d[i - 1].is_ascii_alphanumeric()) {
            let s = i;
            while i < d.len() && num(d[i]) {
                i += 1;
            }
            if d[s..i].iter().any(u8::is_ascii_digit) {
                out.push((s, i));
            }
        } else {
            i += 1;
        }
    }
    out
}

fn lines(d: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    for (i, &c) in d.iter().enumerate() {
        if c == b'\n' {
            out.push((s, i + 1));
            s = i + 1;
        }
    }
    if s < d.len() {
        out.push((s, d.len()));
    }
    out
}

fn text(rng: &mut Rng, d: &mut Vec<u8>, others: &[&[u8]]) {
    match rng.below(8) {
        0..=2 => {
            let spans = number_spans(d);
            if spans.is_empty() {
                return bytes(rng, d, others);
            }
            let (s, e) = *rng.pick(&spans);
            d.splice(s..e, rng.pick(NUMBERS).bytes());
        }
        3 => {
            // A word (whitespace-delimited) replaced.
            let starts: Vec<usize> = (0..d.len())
                .filter(|&i| {
                    !d[i].is_ascii_whitespace() && (i == 0 || d[i - 1].is_ascii_whitespace())
                })
                .collect();
            if starts.is_empty() {
                return bytes(rng, d, others);
            }
            let s = *rng.pick(&starts);
            let e = (s..d.len())
                .find(|&i| d[i].is_ascii_whitespace())
                .unwrap_or(d.len());
            let w = if rng.one_in(16) {
                "a".repeat(1 + rng.below(70_000))
            } else {
                rng.pick(WORDS).to_string()
            };
            d.splice(s..e, w.into_bytes());
        }
        4 => {
            let ls = lines(d);
            if ls.is_empty() {
                return;
            }
            let (s, e) = *rng.pick(&ls);
            d.drain(s..e);
        }
        5 => {
            // A line repeated: once, a few times, or thousands of times (fan-out, counts).
            let ls = lines(d);
            if ls.is_empty() {
                return;
            }
            let (s, e) = *rng.pick(&ls);
            let line = d[s..e].to_vec();
            // Within the input size limit ([`mutate`] truncates to 256 KiB anyway).
            let times = (*rng.pick(&[1usize, 2, 3, 31, 1000, 5000]))
                .min((256 << 10) / line.len().max(1))
                .max(1);
            let rep: Vec<u8> = line
                .iter()
                .copied()
                .cycle()
                .take(line.len() * times)
                .collect();
            d.splice(e..e, rep);
        }
        6 => {
            let ls = lines(d);
            if ls.len() < 2 {
                return;
            }
            let (a, b) = (rng.below(ls.len()), rng.below(ls.len()));
            let (a, b) = (ls[a.min(b)], ls[a.max(b)]);
            if a == b {
                return;
            }
            let mut out = d[..a.0].to_vec();
            out.extend_from_slice(&d[b.0..b.1]);
            out.extend_from_slice(&d[a.1..b.0]);
            out.extend_from_slice(&d[a.0..a.1]);
            out.extend_from_slice(&d[b.1..]);
            *d = out;
        }
        _ => {
            // A line of another seed inserted.
            if others.is_empty() {
                return bytes(rng, d, others);
            }
            let o = *rng.pick(others);
            let ls = lines(o);
            if ls.is_empty() {
                return;
            }
            let (s, e) = *rng.pick(&ls);
            let at = lines(d)
                .get(rng.below(lines(d).len() + 1))
                .map_or(d.len(), |l| l.0);
            d.splice(at..at, o[s..e].iter().copied());
        }
    }
}

/// Mutate one JSON value; false when `d` is not JSON.
fn json(rng: &mut Rng, d: &mut Vec<u8>) -> bool {
    let Ok(mut v) = serde_json::from_slice::<serde_json::Value>(d) else {
        return false;
    };
    let mut count = 0;
    visit(&mut v, &mut |_| count += 1);
    let target = rng.below(count);
    let mut k = 0;
    let mut seed = rng.clone();
    visit(&mut v, &mut |x| {
        if k == target {
            mutate_value(&mut seed, x);
        }
        k += 1;
    });
    *rng = seed;
    *d = serde_json::to_vec(&v).unwrap_or_default();
    true
}

fn visit(v: &mut serde_json::Value, f: &mut dyn FnMut(&mut serde_json::Value)) {
    f(v);
    match v {
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| visit(x, f)),
        serde_json::Value::Object(o) => o.values_mut().for_each(|x| visit(x, f)),
        _ => {}
    }
}

fn mutate_value(rng: &mut Rng, v: &mut serde_json::Value) {
    use serde_json::Value;
    let num = |rng: &mut Rng| -> Value {
        let s = *rng.pick(NUMBERS);
        serde_json::from_str::<Value>(s).unwrap_or(Value::from(-1))
    };
    match v {
        Value::Number(_) => *v = num(rng),
        Value::String(_) => *v = Value::from(*rng.pick(WORDS)),
        Value::Array(a) => match rng.below(4) {
            0 => a.clear(),
            1 if !a.is_empty() => {
                let i = rng.below(a.len());
                a.remove(i);
            }
            2 if !a.is_empty() => {
                let x = a[rng.below(a.len())].clone();
                a.push(x);
            }
            _ => a.push(num(rng)),
        },
        Value::Object(o) => {
            let keys: Vec<String> = o.keys().cloned().collect();
            if !keys.is_empty() && rng.one_in(2) {
                o.remove(&keys[rng.below(keys.len())]);
            } else if !keys.is_empty() {
                // A node's child, a cycle's favourite: point at index 0.
                let k = &keys[rng.below(keys.len())];
                o.insert(k.clone(), Value::from(vec![0, 0]));
            }
        }
        _ => *v = num(rng),
    }
}

fn binary(rng: &mut Rng, d: &mut Vec<u8>) {
    if d.len() < 4 {
        return bytes(rng, d, &[]);
    }
    let at = rng.below(d.len() / 4) * 4;
    if rng.one_in(2) && at + 8 <= d.len() {
        d[at..at + 8].copy_from_slice(&rng.pick(INTS).to_le_bytes());
    } else if rng.one_in(2) {
        d[at..at + 4].copy_from_slice(&(*rng.pick(INTS) as u32).to_le_bytes());
    } else {
        d[at..at + 4].copy_from_slice(&rng.pick(FLOATS).to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mutations_are_deterministic_and_change_inputs() {
        let seed = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec();
        let run = |s: u64| {
            let mut rng = Rng::new(s);
            (0..50)
                .map(|_| {
                    let mut d = seed.clone();
                    mutate(&mut rng, &mut d, Kind::Text, &[&seed]);
                    d
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(7), run(7));
        assert!(run(7).iter().filter(|d| **d != seed).count() > 40);
        assert_eq!(number_spans(b"v 1.5 -2e3 x9"), vec![(2, 5), (6, 10)]);
        let mut j = br#"{"a":[1,{"b":"c"}]}"#.to_vec();
        assert!(json(&mut Rng::new(1), &mut j));
        assert!(!json(&mut Rng::new(1), &mut b"{".to_vec()));
    }
}
