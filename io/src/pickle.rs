//! A small, strict reader and writer for Python pickles of dicts of numpy arrays — exactly the subset AIST++
//! motion files use.
//!
//! Reading runs a pickle virtual machine over protocols 2–5 that understands the numpy reconstruction paths of
//! numpy 1.x (`numpy.core.multiarray`) and 2.x (`numpy._core.multiarray`): `_reconstruct` + `BUILD`,
//! protocol 5's `_frombuffer` (in-band buffers), numpy scalars, and protocol 2's `_codecs.encode` for bytes.
//! Anything else (arbitrary classes) is kept as an opaque object and only fails if the caller asks for it.
//! Every length is checked against the remaining input, so a malicious header cannot make us allocate.
//!
//! Writing produces protocol 3 with `numpy.core.multiarray._reconstruct`, which every numpy from 1.x to 2.x
//! reads with `pickle.load`.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

use crate::error::{Error, Result};

/// Element type of a numpy array as stored on disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DType {
    F2,
    F4,
    F8,
    I1,
    I2,
    I4,
    I8,
    U1,
    U2,
    U4,
    U8,
    Bool,
}

impl DType {
    /// Parse a numpy type string such as `f8`, `<f4`, `float64`, `int32`; returns the type and whether the
    /// string fixes big-endian order.
    pub fn parse(s: &str) -> Option<(DType, Option<bool>)> {
        let (big, body) = match s.as_bytes().first() {
            Some(b'<') => (Some(false), &s[1..]),
            Some(b'>') => (Some(true), &s[1..]),
            Some(b'|') | Some(b'=') => (None, &s[1..]),
            _ => (None, s),
        };
        let t = match body {
            "f2" | "float16" | "e" => DType::F2,
            "f4" | "float32" | "f" => DType::F4,
            "f8" | "float64" | "d" | "float" => DType::F8,
            "i1" | "int8" | "b" => DType::I1,
            "i2" | "int16" | "h" => DType::I2,
            "i4" | "int32" | "i" => DType::I4,
            "i8" | "int64" | "l" | "q" | "int" => DType::I8,
            "u1" | "uint8" | "B" => DType::U1,
            "u2" | "uint16" | "H" => DType::U2,
            "u4" | "uint32" | "I" => DType::U4,
            "u8" | "uint64" | "L" | "Q" => DType::U8,
            "b1" | "bool" | "?" => DType::Bool,
            _ => return None,
        };
        Some((t, big))
    }

    pub fn size(self) -> usize {
        match self {
            DType::I1 | DType::U1 | DType::Bool => 1,
            DType::F2 | DType::I2 | DType::U2 => 2,
            DType::F4 | DType::I4 | DType::U4 => 4,
            DType::F8 | DType::I8 | DType::U8 => 8,
        }
    }

    /// The numpy type string without byte order (`f8`, `i4`, ...).
    pub fn code(self) -> &'static str {
        match self {
            DType::F2 => "f2",
            DType::F4 => "f4",
            DType::F8 => "f8",
            DType::I1 => "i1",
            DType::I2 => "i2",
            DType::I4 => "i4",
            DType::I8 => "i8",
            DType::U1 => "u1",
            DType::U2 => "u2",
            DType::U4 => "u4",
            DType::U8 => "u8",
            DType::Bool => "b1",
        }
    }

    /// Decode `bytes` (whose length is a multiple of the item size) into f64 values.
    pub fn decode(self, bytes: &[u8], big_endian: bool) -> Vec<f64> {
        let n = self.size();
        bytes
            .chunks_exact(n)
            .map(|c| {
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(c);
                if big_endian {
                    b[..n].reverse();
                }
                match self {
                    DType::F2 => f16_to_f64(u16::from_le_bytes([b[0], b[1]])),
                    DType::F4 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    DType::F8 => f64::from_le_bytes(b),
                    DType::I1 => b[0] as i8 as f64,
                    DType::I2 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    DType::I4 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    DType::I8 => i64::from_le_bytes(b) as f64,
                    DType::U1 | DType::Bool => b[0] as f64,
                    DType::U2 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    DType::U4 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    DType::U8 => u64::from_le_bytes(b) as f64,
                }
            })
            .collect()
    }
}

fn f16_to_f64(h: u16) -> f64 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f64;
    match exp {
        0 => sign * frac * 2f64.powi(-24),
        31 if frac == 0.0 => sign * f64::INFINITY,
        31 => f64::NAN,
        _ => sign * (1.0 + frac / 1024.0) * 2f64.powi(exp - 15),
    }
}

/// A numpy array read from a pickle or `.npy` file: values widened to f64 (lossless for f32/f64), C order.
#[derive(Debug, Clone, PartialEq)]
pub struct NdArray {
    pub shape: Vec<usize>,
    /// The element type on disk.
    pub dtype: DType,
    pub data: Vec<f64>,
}

impl NdArray {
    pub fn new(shape: Vec<usize>, dtype: DType, data: Vec<f64>) -> Self {
        debug_assert_eq!(shape.iter().product::<usize>(), data.len());
        NdArray { shape, dtype, data }
    }

    pub fn len(&self) -> usize {
        self.data.len()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}

/// A decoded pickle value (the subset we understand; everything else is `Object`).
#[derive(Debug, Clone)]
pub enum Value {
    None,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    Bytes(Vec<u8>),
    Tuple(Vec<Value>),
    List(Vec<Value>),
    Dict(Vec<(Value, Value)>),
    Array(Rc<RefCell<ArrayState>>),
    /// A `module.name` reference, not yet called.
    Global(String, String),
    /// Something we do not model (an arbitrary class instance); carries its constructor's name.
    Object(String),
}

/// An ndarray under construction (`_reconstruct` gives an empty one; `BUILD` fills it) or a numpy dtype.
#[derive(Debug, Clone)]
pub enum ArrayState {
    Pending,
    Ready(NdArray),
    Dtype {
        dtype: Option<DType>,
        big_endian: bool,
    },
}

impl Value {
    fn type_name(&self) -> String {
        match self {
            Value::None => "None".into(),
            Value::Bool(_) => "bool".into(),
            Value::Int(_) => "int".into(),
            Value::Float(_) => "float".into(),
            Value::Str(_) => "str".into(),
            Value::Bytes(_) => "bytes".into(),
            Value::Tuple(_) => "tuple".into(),
            Value::List(_) => "list".into(),
            Value::Dict(_) => "dict".into(),
            Value::Array(a) => match &*a.borrow() {
                ArrayState::Dtype { .. } => "numpy.dtype".into(),
                _ => "numpy.ndarray".into(),
            },
            Value::Global(m, n) => format!("{m}.{n}"),
            Value::Object(n) => n.clone(),
        }
    }

    /// This value as an array: numpy arrays, and also Python numbers and (nested) lists of numbers.
    pub fn to_array(&self) -> std::result::Result<NdArray, String> {
        match self {
            Value::Array(a) => match &*a.borrow() {
                ArrayState::Ready(arr) => Ok(arr.clone()),
                ArrayState::Pending => Err("numpy array without data (no BUILD)".into()),
                ArrayState::Dtype { .. } => Err("a numpy dtype, not an array".into()),
            },
            Value::Float(f) => Ok(NdArray::new(vec![], DType::F8, vec![*f])),
            Value::Int(i) => Ok(NdArray::new(vec![], DType::I8, vec![*i as f64])),
            Value::List(items) | Value::Tuple(items) => {
                let parts: Vec<NdArray> = items
                    .iter()
                    .map(|v| v.to_array())
                    .collect::<std::result::Result<_, _>>()?;
                let inner = parts.first().map(|p| p.shape.clone()).unwrap_or_default();
                if parts.iter().any(|p| p.shape != inner) {
                    return Err("ragged nested list".into());
                }
                let mut shape = vec![parts.len()];
                shape.extend(inner);
                let data = parts.into_iter().flat_map(|p| p.data).collect();
                Ok(NdArray::new(shape, DType::F8, data))
            }
            other => Err(format!("expected an array, found {}", other.type_name())),
        }
    }
}

const MAX_DEPTH_ITEMS: usize = 1 << 24;

/// Parse a pickle. Errors are plain messages (the caller adds the file name).
pub fn loads(input: &[u8]) -> std::result::Result<Value, String> {
    Vm::new(input).run()
}

/// Read a pickle file that holds a dict with string keys (as AIST++ motion files do).
pub fn read_dict(path: &std::path::Path) -> Result<Vec<(String, Value)>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if bytes.is_empty() {
        return Err(Error::at(path, "empty file (expected a Python pickle)"));
    }
    let value =
        loads(&bytes).map_err(|m| Error::at(path, format!("not a readable pickle: {m}")))?;
    match value {
        Value::Dict(items) => items
            .into_iter()
            .map(|(k, v)| match k {
                Value::Str(s) => Ok((s, v)),
                other => Err(Error::at(
                    path,
                    format!("pickle dict has a non-string key ({})", other.type_name()),
                )),
            })
            .collect(),
        other => Err(Error::at(
            path,
            format!(
                "pickle holds a {}, expected a dict of arrays",
                other.type_name()
            ),
        )),
    }
}

struct Vm<'a> {
    input: &'a [u8],
    pos: usize,
    stack: Vec<Value>,
    marks: Vec<usize>,
    memo: HashMap<u32, Value>,
    /// Work spent deep-copying values (DUP, PUT, GET), against [`copy_budget`]: a few hundred bytes of
    /// DUP/APPEND can otherwise nest copies of copies into gigabytes ("pickle bomb").
    copied: usize,
}

/// How much copying a pickle of `len` bytes may do: ample for real files (each value is copied a few
/// times), bounded for hostile ones.
fn copy_budget(len: usize) -> usize {
    1_000_000 + 64 * len
}

/// The copying cost of `v` (nodes, plus a unit per 64 bytes of strings), counted only up to `limit`.
fn copy_cost(v: &Value, limit: usize) -> usize {
    let mut cost = 0;
    let mut todo = vec![v];
    while let Some(v) = todo.pop() {
        cost += 1;
        match v {
            Value::Str(s) => cost += s.len() / 64,
            Value::Bytes(b) => cost += b.len() / 64,
            Value::Tuple(items) | Value::List(items) => todo.extend(items.iter()),
            Value::Dict(items) => {
                for (k, x) in items {
                    todo.push(k);
                    todo.push(x);
                }
            }
            _ => {}
        }
        if cost > limit {
            break;
        }
    }
    cost
}

impl<'a> Vm<'a> {
    fn new(input: &'a [u8]) -> Self {
        Vm {
            input,
            pos: 0,
            stack: Vec::new(),
            marks: Vec::new(),
            memo: HashMap::new(),
            copied: 0,
        }
    }

    /// Charges a copy of `cost` to the budget, failing once it is spent.
    fn charge(&mut self, cost: usize) -> std::result::Result<(), String> {
        let budget = copy_budget(self.input.len());
        self.copied = self.copied.saturating_add(cost);
        if self.copied > budget {
            return Err(format!(
                "too many nested copies (more than {budget} objects from {} bytes): not an AIST++ pickle",
                self.input.len()
            ));
        }
        Ok(())
    }

    /// A deep copy of the top of the stack, charged to the copy budget before it is made.
    fn copy_top(&mut self) -> std::result::Result<Value, String> {
        let budget = copy_budget(self.input.len());
        let cost = copy_cost(self.top()?, budget);
        self.charge(cost)?;
        Ok(self.top()?.clone())
    }

    fn take(&mut self, n: usize) -> std::result::Result<&'a [u8], String> {
        if n > self.input.len() - self.pos {
            return Err(format!(
                "truncated: needs {n} bytes at offset {} but only {} remain",
                self.pos,
                self.input.len() - self.pos
            ));
        }
        let s = &self.input[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn u8(&mut self) -> std::result::Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn u16(&mut self) -> std::result::Result<u16, String> {
        let b = self.take(2)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }
    fn u32(&mut self) -> std::result::Result<u32, String> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self) -> std::result::Result<u64, String> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(b.try_into().unwrap()))
    }
    fn line(&mut self) -> std::result::Result<&'a str, String> {
        let rest = &self.input[self.pos..];
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or("truncated: unterminated text argument")?;
        self.pos += end + 1;
        std::str::from_utf8(&rest[..end]).map_err(|_| "invalid UTF-8 in text argument".to_string())
    }
    fn utf8(&mut self, n: usize) -> std::result::Result<String, String> {
        let b = self.take(n)?;
        String::from_utf8(b.to_vec()).map_err(|_| "invalid UTF-8 string".to_string())
    }
    fn len64(&mut self) -> std::result::Result<usize, String> {
        let n = self.u64()?;
        usize::try_from(n).map_err(|_| "length out of range".to_string())
    }

    fn pop(&mut self) -> std::result::Result<Value, String> {
        if let Some(&m) = self.marks.last() {
            if self.stack.len() <= m {
                return Err("stack underflow (pop below mark)".into());
            }
        }
        self.stack
            .pop()
            .ok_or_else(|| "stack underflow".to_string())
    }
    fn top(&mut self) -> std::result::Result<&mut Value, String> {
        self.stack
            .last_mut()
            .ok_or_else(|| "stack underflow".to_string())
    }
    fn pop_mark(&mut self) -> std::result::Result<Vec<Value>, String> {
        let m = self.marks.pop().ok_or("MARK missing")?;
        if m > self.stack.len() {
            return Err("corrupt MARK".into());
        }
        Ok(self.stack.split_off(m))
    }
    fn push(&mut self, v: Value) -> std::result::Result<(), String> {
        if self.stack.len() > MAX_DEPTH_ITEMS {
            return Err("too many objects on the pickle stack".into());
        }
        self.stack.push(v);
        Ok(())
    }

    fn run(mut self) -> std::result::Result<Value, String> {
        loop {
            let op = self.u8()?;
            match op {
                0x80 => {
                    let proto = self.u8()?;
                    if proto > 5 {
                        return Err(format!("unsupported pickle protocol {proto}"));
                    }
                }
                0x95 => {
                    self.u64()?; // FRAME: a length hint only
                }
                b'.' => {
                    // STOP
                    let v = self.pop()?;
                    return Ok(v);
                }
                b'(' => self.marks.push(self.stack.len()),
                b'0' => {
                    self.pop()?;
                }
                b'1' => {
                    self.pop_mark()?;
                }
                b'2' => {
                    let v = self.copy_top()?;
                    self.push(v)?;
                }
                b'N' => self.push(Value::None)?,
                0x88 => self.push(Value::Bool(true))?,
                0x89 => self.push(Value::Bool(false))?,
                b'J' => {
                    let v = self.u32()? as i32 as i64;
                    self.push(Value::Int(v))?
                }
                b'K' => {
                    let v = self.u8()? as i64;
                    self.push(Value::Int(v))?
                }
                b'M' => {
                    let v = self.u16()? as i64;
                    self.push(Value::Int(v))?
                }
                b'I' => {
                    let l = self.line()?;
                    let v = match l {
                        "00" => Value::Bool(false),
                        "01" => Value::Bool(true),
                        _ => Value::Int(l.trim().parse().map_err(|_| "bad INT")?),
                    };
                    self.push(v)?
                }
                b'L' => {
                    let l = self.line()?.trim_end_matches('L');
                    self.push(Value::Int(l.parse().map_err(|_| "LONG out of range")?))?
                }
                0x8a | 0x8b => {
                    let n = if op == 0x8a {
                        self.u8()? as usize
                    } else {
                        self.u32()? as usize
                    };
                    if n > 8 {
                        return Err("integer too large".into());
                    }
                    let b = self.take(n)?;
                    let mut buf = if b.last().is_some_and(|&x| x & 0x80 != 0) {
                        [0xffu8; 8]
                    } else {
                        [0u8; 8]
                    };
                    buf[..n].copy_from_slice(b);
                    self.push(Value::Int(i64::from_le_bytes(buf)))?
                }
                b'G' => {
                    let b = self.take(8)?;
                    self.push(Value::Float(f64::from_be_bytes(b.try_into().unwrap())))?
                }
                b'F' => {
                    let l = self.line()?;
                    self.push(Value::Float(l.trim().parse().map_err(|_| "bad FLOAT")?))?
                }
                0x8c => {
                    let n = self.u8()? as usize;
                    let s = self.utf8(n)?;
                    self.push(Value::Str(s))?
                }
                b'X' => {
                    let n = self.u32()? as usize;
                    let s = self.utf8(n)?;
                    self.push(Value::Str(s))?
                }
                0x8d => {
                    let n = self.len64()?;
                    let s = self.utf8(n)?;
                    self.push(Value::Str(s))?
                }
                b'V' => {
                    let s = self.line()?.to_string();
                    self.push(Value::Str(s))?
                }
                b'C' | b'U' => {
                    // SHORT_BINBYTES / SHORT_BINSTRING (py2 str: raw bytes)
                    let n = self.u8()? as usize;
                    let b = self.take(n)?.to_vec();
                    self.push(Value::Bytes(b))?
                }
                b'B' | b'T' => {
                    let n = self.u32()? as usize;
                    let b = self.take(n)?.to_vec();
                    self.push(Value::Bytes(b))?
                }
                0x8e | 0x96 => {
                    // BINBYTES8 / BYTEARRAY8
                    let n = self.len64()?;
                    let b = self.take(n)?.to_vec();
                    self.push(Value::Bytes(b))?
                }
                0x97 | 0x98 => {
                    return Err(
                        "out-of-band buffers (protocol 5 NEXT_BUFFER) are not supported".into(),
                    )
                }
                b')' => self.push(Value::Tuple(vec![]))?,
                0x85 => {
                    let a = self.pop()?;
                    self.push(Value::Tuple(vec![a]))?
                }
                0x86 => {
                    let b = self.pop()?;
                    let a = self.pop()?;
                    self.push(Value::Tuple(vec![a, b]))?
                }
                0x87 => {
                    let c = self.pop()?;
                    let b = self.pop()?;
                    let a = self.pop()?;
                    self.push(Value::Tuple(vec![a, b, c]))?
                }
                b't' => {
                    let items = self.pop_mark()?;
                    self.push(Value::Tuple(items))?
                }
                b']' => self.push(Value::List(vec![]))?,
                b'l' => {
                    let items = self.pop_mark()?;
                    self.push(Value::List(items))?
                }
                b'a' => {
                    let v = self.pop()?;
                    match self.top()? {
                        Value::List(l) => l.push(v),
                        _ => return Err("APPEND to a non-list".into()),
                    }
                }
                b'e' => {
                    let items = self.pop_mark()?;
                    match self.top()? {
                        Value::List(l) => l.extend(items),
                        _ => return Err("APPENDS to a non-list".into()),
                    }
                }
                b'}' => self.push(Value::Dict(vec![]))?,
                b'd' => {
                    let items = self.pop_mark()?;
                    let d = pairs(items)?;
                    self.push(Value::Dict(d))?
                }
                b's' => {
                    let v = self.pop()?;
                    let k = self.pop()?;
                    dict_insert(self.top()?, vec![(k, v)])?;
                }
                b'u' => {
                    let items = self.pop_mark()?;
                    let d = pairs(items)?;
                    dict_insert(self.top()?, d)?;
                }
                0x8f => self.push(Value::List(vec![]))?, // EMPTY_SET, modelled as a list
                0x90 => {
                    let items = self.pop_mark()?;
                    match self.top()? {
                        Value::List(l) => l.extend(items),
                        _ => return Err("ADDITEMS to a non-set".into()),
                    }
                }
                0x91 => {
                    let items = self.pop_mark()?;
                    self.push(Value::List(items))?
                }
                b'c' => {
                    let module = self.line()?.to_string();
                    let name = self.line()?.to_string();
                    self.push(Value::Global(module, name))?
                }
                0x93 => {
                    let name = self.pop()?;
                    let module = self.pop()?;
                    match (module, name) {
                        (Value::Str(m), Value::Str(n)) => self.push(Value::Global(m, n))?,
                        _ => return Err("STACK_GLOBAL needs two strings".into()),
                    }
                }
                b'R' => {
                    let args = self.pop()?;
                    let callable = self.pop()?;
                    let v = reduce(callable, args)?;
                    self.push(v)?
                }
                0x81 => {
                    // NEWOBJ: cls.__new__(cls, *args)
                    let _args = self.pop()?;
                    let cls = self.pop()?;
                    self.push(Value::Object(cls.type_name()))?
                }
                0x92 => {
                    let _kwargs = self.pop()?;
                    let _args = self.pop()?;
                    let cls = self.pop()?;
                    self.push(Value::Object(cls.type_name()))?
                }
                b'b' => {
                    let state = self.pop()?;
                    build(self.top()?, state)?;
                }
                b'p' => {
                    let idx: u32 = self.line()?.trim().parse().map_err(|_| "bad PUT")?;
                    let v = self.copy_top()?;
                    self.memo.insert(idx, v);
                }
                b'q' => {
                    let idx = self.u8()? as u32;
                    let v = self.copy_top()?;
                    self.memo.insert(idx, v);
                }
                b'r' => {
                    let idx = self.u32()?;
                    let v = self.copy_top()?;
                    self.memo.insert(idx, v);
                }
                0x94 => {
                    let idx = self.memo.len() as u32;
                    let v = self.copy_top()?;
                    self.memo.insert(idx, v);
                }
                b'g' => {
                    let idx: u32 = self.line()?.trim().parse().map_err(|_| "bad GET")?;
                    self.get(idx)?
                }
                b'h' => {
                    let idx = self.u8()? as u32;
                    self.get(idx)?
                }
                b'j' => {
                    let idx = self.u32()?;
                    self.get(idx)?
                }
                other => {
                    return Err(format!(
                        "unsupported pickle opcode 0x{other:02x} at offset {}",
                        self.pos - 1
                    ))
                }
            }
        }
    }

    fn get(&mut self, idx: u32) -> std::result::Result<(), String> {
        let missing = || format!("memo key {idx} missing");
        let cost = copy_cost(
            self.memo.get(&idx).ok_or_else(missing)?,
            copy_budget(self.input.len()),
        );
        self.charge(cost)?;
        let v = self.memo.get(&idx).cloned().ok_or_else(missing)?;
        self.push(v)
    }
}

fn pairs(items: Vec<Value>) -> std::result::Result<Vec<(Value, Value)>, String> {
    if !items.len().is_multiple_of(2) {
        return Err("odd number of items for a dict".into());
    }
    let mut out = Vec::with_capacity(items.len() / 2);
    let mut it = items.into_iter();
    while let (Some(k), Some(v)) = (it.next(), it.next()) {
        out.push((k, v));
    }
    Ok(out)
}

fn dict_insert(target: &mut Value, items: Vec<(Value, Value)>) -> std::result::Result<(), String> {
    match target {
        Value::Dict(d) => {
            for (k, v) in items {
                // Later keys replace earlier ones, as in Python.
                if let Value::Str(ks) = &k {
                    if let Some(slot) = d
                        .iter_mut()
                        .find(|(ek, _)| matches!(ek, Value::Str(s) if s == ks))
                    {
                        slot.1 = v;
                        continue;
                    }
                }
                d.push((k, v));
            }
            Ok(())
        }
        _ => Err("SETITEM on a non-dict".into()),
    }
}

fn is_numpy_core(module: &str, sub: &str) -> bool {
    module == format!("numpy.core.{sub}") || module == format!("numpy._core.{sub}")
}

fn dtype_of(v: &Value) -> std::result::Result<(DType, bool), String> {
    match v {
        Value::Array(a) => match &*a.borrow() {
            ArrayState::Dtype {
                dtype: Some(d),
                big_endian,
            } => Ok((*d, *big_endian)),
            ArrayState::Dtype { dtype: None, .. } => Err("unsupported numpy dtype".into()),
            _ => Err("expected a numpy dtype".into()),
        },
        other => Err(format!(
            "expected a numpy dtype, found {}",
            other.type_name()
        )),
    }
}

fn shape_of(v: &Value) -> std::result::Result<Vec<usize>, String> {
    let items = match v {
        Value::Tuple(t) | Value::List(t) => t,
        Value::Int(_) => std::slice::from_ref(v),
        other => {
            return Err(format!(
                "array shape must be a tuple, found {}",
                other.type_name()
            ))
        }
    };
    let mut shape = Vec::with_capacity(items.len());
    let mut total: usize = 1;
    for it in items {
        match it {
            Value::Int(n) if *n >= 0 => {
                let n = *n as usize;
                total = total.checked_mul(n).ok_or("array shape overflows")?;
                shape.push(n);
            }
            _ => return Err("array shape must hold non-negative integers".into()),
        }
    }
    Ok(shape)
}

fn make_array(
    shape: Vec<usize>,
    dtype: DType,
    big_endian: bool,
    fortran: bool,
    raw: &[u8],
) -> std::result::Result<NdArray, String> {
    let count: usize = shape.iter().product();
    let want = count
        .checked_mul(dtype.size())
        .ok_or("array size overflows")?;
    if raw.len() != want {
        return Err(format!(
            "array data has {} bytes but shape {:?} of {} needs {}",
            raw.len(),
            shape,
            dtype.code(),
            want
        ));
    }
    let mut data = dtype.decode(raw, big_endian);
    if fortran && shape.len() > 1 {
        data = fortran_to_c(&data, &shape);
    }
    Ok(NdArray::new(shape, dtype, data))
}

/// Reorder Fortran-order (column-major) data into C order.
pub(crate) fn fortran_to_c(data: &[f64], shape: &[usize]) -> Vec<f64> {
    let n = data.len();
    let mut out = vec![0.0; n];
    let mut idx = vec![0usize; shape.len()];
    for v in out.iter_mut() {
        // idx walks C order; compute its Fortran offset.
        let mut off = 0;
        let mut stride = 1;
        for (d, &i) in idx.iter().enumerate() {
            off += i * stride;
            stride *= shape[d];
        }
        *v = data[off];
        for d in (0..shape.len()).rev() {
            idx[d] += 1;
            if idx[d] < shape[d] {
                break;
            }
            idx[d] = 0;
        }
    }
    out
}

fn reduce(callable: Value, args: Value) -> std::result::Result<Value, String> {
    let (module, name) = match &callable {
        Value::Global(m, n) => (m.as_str(), n.as_str()),
        other => return Ok(Value::Object(other.type_name())),
    };
    let args = match args {
        Value::Tuple(a) => a,
        other => {
            return Err(format!(
                "REDUCE arguments must be a tuple, found {}",
                other.type_name()
            ))
        }
    };
    if is_numpy_core(module, "multiarray") && name == "_reconstruct" {
        return Ok(Value::Array(Rc::new(RefCell::new(ArrayState::Pending))));
    }
    if module == "numpy" && name == "dtype" {
        let code = match args.first() {
            Some(Value::Str(s)) => s.clone(),
            _ => return Err("numpy.dtype needs a type string".into()),
        };
        let parsed = DType::parse(&code);
        return Ok(Value::Array(Rc::new(RefCell::new(ArrayState::Dtype {
            dtype: parsed.map(|p| p.0),
            big_endian: parsed.and_then(|p| p.1).unwrap_or(false),
        }))));
    }
    if (is_numpy_core(module, "numeric") || module == "numpy") && name == "_frombuffer" {
        // Protocol 5: _frombuffer(buffer, dtype, shape, order)
        if args.len() != 4 {
            return Err("_frombuffer needs 4 arguments".into());
        }
        let raw = match &args[0] {
            Value::Bytes(b) => b,
            _ => return Err("_frombuffer needs an in-band buffer".into()),
        };
        let (dtype, big) = dtype_of(&args[1])?;
        let shape = shape_of(&args[2])?;
        let fortran = matches!(&args[3], Value::Str(s) if s == "F");
        let arr = make_array(shape, dtype, big, fortran, raw)?;
        return Ok(Value::Array(Rc::new(RefCell::new(ArrayState::Ready(arr)))));
    }
    if is_numpy_core(module, "multiarray") && name == "scalar" {
        let (dtype, big) = dtype_of(args.first().ok_or("scalar needs a dtype")?)?;
        let raw = match args.get(1) {
            Some(Value::Bytes(b)) => b,
            _ => return Err("numpy scalar needs its bytes".into()),
        };
        let arr = make_array(vec![], dtype, big, false, raw)?;
        return Ok(Value::Array(Rc::new(RefCell::new(ArrayState::Ready(arr)))));
    }
    if module == "_codecs" && name == "encode" {
        // Protocol 2 pickles bytes as _codecs.encode(str, 'latin1').
        return match args.first() {
            Some(Value::Str(s)) => s
                .chars()
                .map(|c| u8::try_from(c as u32).map_err(|_| "non-latin1 bytes".to_string()))
                .collect::<std::result::Result<Vec<u8>, _>>()
                .map(Value::Bytes),
            _ => Err("_codecs.encode needs a string".into()),
        };
    }
    if (module == "builtins" || module == "__builtin__") && name == "bytearray" {
        return match args.first() {
            Some(Value::Bytes(b)) => Ok(Value::Bytes(b.clone())),
            None => Ok(Value::Bytes(vec![])),
            _ => Err("bytearray argument not supported".into()),
        };
    }
    Ok(Value::Object(format!("{module}.{name}")))
}

fn build(target: &mut Value, state: Value) -> std::result::Result<(), String> {
    let cell = match target {
        Value::Array(a) => a.clone(),
        // Opaque objects accept any state.
        _ => return Ok(()),
    };
    let mut slot = cell.borrow_mut();
    let st = match state {
        Value::Tuple(t) => t,
        other => {
            return Err(format!(
                "numpy BUILD state must be a tuple, found {}",
                other.type_name()
            ))
        }
    };
    match &mut *slot {
        ArrayState::Dtype { big_endian, .. } => {
            // (version, byteorder, subarray, names, fields, elsize, alignment, flags)
            if let Some(Value::Str(order)) = st.get(1) {
                *big_endian = order == ">";
            }
            Ok(())
        }
        ArrayState::Pending | ArrayState::Ready(_) => {
            // (version, shape, dtype, is_fortran, rawdata)
            let st = if st.len() == 5 { &st[1..] } else { &st[..] };
            if st.len() != 4 {
                return Err("numpy array state has the wrong length".into());
            }
            let shape = shape_of(&st[0])?;
            let (dtype, big) = dtype_of(&st[1])?;
            let fortran = matches!(st[2], Value::Bool(true) | Value::Int(1));
            let raw = match &st[3] {
                Value::Bytes(b) => b,
                Value::List(_) => return Err("object arrays are not supported".into()),
                other => {
                    return Err(format!(
                        "array data must be bytes, found {}",
                        other.type_name()
                    ))
                }
            };
            *slot = ArrayState::Ready(make_array(shape, dtype, big, fortran, raw)?);
            Ok(())
        }
    }
}

/// An array to write: f32 or f64 values in C order.
pub enum ArrayRef<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
}

/// Serialise a dict of arrays (plus plain integers) as a protocol-3 pickle that numpy 1.x and 2.x read back.
pub fn dumps_dict(items: &[(&str, &[usize], ArrayRef<'_>)], ints: &[(&str, i64)]) -> Vec<u8> {
    let mut out = vec![0x80, 3, b'}', b'('];
    for (key, shape, arr) in items {
        let (code, bytes): (&str, Vec<u8>) = match arr {
            ArrayRef::F32(v) => {
                debug_assert_eq!(v.len(), shape.iter().product::<usize>());
                ("f4", v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
            ArrayRef::F64(v) => {
                debug_assert_eq!(v.len(), shape.iter().product::<usize>());
                ("f8", v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
        };
        put_str(&mut out, key);
        out.extend_from_slice(b"cnumpy.core.multiarray\n_reconstruct\n");
        out.extend_from_slice(b"cnumpy\nndarray\n");
        out.extend_from_slice(&[b'K', 0, 0x85]); // (0,)
        out.extend_from_slice(&[b'C', 1, b'b', 0x87, b'R']);
        out.push(b'(');
        put_int(&mut out, 1);
        out.push(b'(');
        for &d in shape.iter() {
            put_int(&mut out, d as i64);
        }
        out.push(b't');
        out.extend_from_slice(b"cnumpy\ndtype\n");
        put_str(&mut out, code);
        out.extend_from_slice(&[0x89, 0x88, 0x87, b'R', b'(']);
        put_int(&mut out, 3);
        put_str(&mut out, "<");
        out.extend_from_slice(b"NNN");
        put_int(&mut out, -1);
        put_int(&mut out, -1);
        put_int(&mut out, 0);
        out.extend_from_slice(b"tb");
        out.push(0x89); // is_fortran = False
        out.push(b'B');
        out.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(&bytes);
        out.extend_from_slice(b"tb");
    }
    for (key, v) in ints {
        put_str(&mut out, key);
        put_int(&mut out, *v);
    }
    out.extend_from_slice(b"u.");
    out
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    out.push(b'X');
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

fn put_int(out: &mut Vec<u8>, v: i64) {
    if (0..256).contains(&v) {
        out.extend_from_slice(&[b'K', v as u8]);
    } else {
        out.push(b'J');
        out.extend_from_slice(&(v as i32).to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pickle_bomb_is_refused_quickly() {
        // EMPTY_LIST, then 40 × (DUP, APPEND): each step doubles the nested copies (2^40 nodes).
        let mut bomb = vec![0x80, 2, b']'];
        for _ in 0..40 {
            bomb.extend_from_slice(b"2a");
        }
        bomb.push(b'.');
        let err = loads(&bomb).unwrap_err();
        assert!(err.contains("too many nested copies"), "{err}");
        // The input libFuzzer found (fuzz/regressions/pickle/).
        let found = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../fuzz/regressions/pickle/oom-pickle-bomb-dup-append"
        ))
        .unwrap();
        assert!(loads(&found).is_err());
    }

    fn dict_get<'a>(v: &'a Value, key: &str) -> &'a Value {
        match v {
            Value::Dict(d) => {
                &d.iter()
                    .find(|(k, _)| matches!(k, Value::Str(s) if s == key))
                    .unwrap()
                    .1
            }
            _ => panic!("not a dict"),
        }
    }

    #[test]
    fn round_trip_our_writer() {
        let a: Vec<f64> = (0..12).map(|i| i as f64 * 0.5 - 1.0).collect();
        let b: Vec<f32> = vec![1.5, -2.25, 3.0];
        let bytes = dumps_dict(
            &[
                ("a", &[3, 4], ArrayRef::F64(&a)),
                ("b", &[3], ArrayRef::F32(&b)),
            ],
            &[("n", 120), ("neg", -7)],
        );
        let v = loads(&bytes).unwrap();
        let arr = dict_get(&v, "a").to_array().unwrap();
        assert_eq!(arr.shape, vec![3, 4]);
        assert_eq!(arr.dtype, DType::F8);
        assert_eq!(arr.data, a);
        let arr = dict_get(&v, "b").to_array().unwrap();
        assert_eq!(arr.dtype, DType::F4);
        assert_eq!(arr.data, vec![1.5, -2.25, 3.0]);
        assert!(matches!(dict_get(&v, "n"), Value::Int(120)));
        assert!(matches!(dict_get(&v, "neg"), Value::Int(-7)));
    }

    #[test]
    fn truncation_is_an_error_at_every_length() {
        let a = vec![0.25f64; 30];
        let bytes = dumps_dict(&[("a", &[10, 3], ArrayRef::F64(&a))], &[]);
        for n in 0..bytes.len() {
            assert!(loads(&bytes[..n]).is_err(), "prefix of {n} bytes parsed");
        }
    }

    #[test]
    fn huge_declared_length_does_not_allocate() {
        // PROTO 4, BINBYTES8 with a length of 2^60.
        let mut b = vec![0x80, 4, 0x8e];
        b.extend_from_slice(&(1u64 << 60).to_le_bytes());
        let e = loads(&b).unwrap_err();
        assert!(e.contains("truncated"), "{e}");
    }

    #[test]
    fn fortran_order() {
        // [[1,2,3],[4,5,6]] stored column-major is 1,4,2,5,3,6.
        let c = fortran_to_c(&[1., 4., 2., 5., 3., 6.], &[2, 3]);
        assert_eq!(c, vec![1., 2., 3., 4., 5., 6.]);
    }
}
