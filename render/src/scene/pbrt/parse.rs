//! Tokens and statements of pbrt-v4's scene description: a directive (a bare word), its
//! positional arguments (numbers, strings, bracketed lists) and its parameter list
//! (`"type name" value` or `"type name" [ values ]`). `#` starts a comment to the end of the
//! line. Every token carries its file and line, and so does every error.

use std::fmt;
use std::rc::Rc;

/// Where a token or statement is: `file:line`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Loc {
    /// The file as given (the main file's path, or an included file's).
    pub file: Rc<str>,
    /// 1-based line.
    pub line: usize,
}

impl fmt::Display for Loc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file, self.line)
    }
}

/// One token.
#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    /// A bare word: a directive, or `true` / `false`.
    Word(String),
    /// A quoted string.
    Str(String),
    /// A number, parsed both in double precision and (correctly rounded) in single precision.
    Num(f64, f32),
    /// `[`.
    Open,
    /// `]`.
    Close,
}

impl fmt::Display for Tok {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tok::Word(w) => write!(f, "{w}"),
            Tok::Str(s) => write!(f, "\"{s}\""),
            Tok::Num(v, _) => write!(f, "{v}"),
            Tok::Open => write!(f, "["),
            Tok::Close => write!(f, "]"),
        }
    }
}

/// The tokens of `text` (the file `file`), each with its line; `Err` names `file:line` of an
/// unterminated string or a character that starts no token.
pub fn tokenize(text: &str, file: &Rc<str>) -> Result<Vec<(Tok, Loc)>, String> {
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let mut i = 0;
    let mut line = 1;
    let loc = |line| Loc {
        file: file.clone(),
        line,
    };
    while i < bytes.len() {
        let c = bytes[i];
        match c {
            b'\n' => {
                line += 1;
                i += 1;
            }
            b' ' | b'\t' | b'\r' | b',' => i += 1,
            b'#' => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
            b'[' => {
                out.push((Tok::Open, loc(line)));
                i += 1;
            }
            b']' => {
                out.push((Tok::Close, loc(line)));
                i += 1;
            }
            b'"' => {
                let start_line = line;
                let mut s = String::new();
                i += 1;
                loop {
                    let Some(&b) = bytes.get(i) else {
                        return Err(format!("{}: unterminated string", loc(start_line)));
                    };
                    match b {
                        b'"' => {
                            i += 1;
                            break;
                        }
                        b'\n' => {
                            return Err(format!("{}: unterminated string", loc(start_line)));
                        }
                        b'\\' => {
                            let e = bytes.get(i + 1).copied().unwrap_or(b'\\');
                            s.push(match e {
                                b'n' => '\n',
                                b't' => '\t',
                                other => other as char,
                            });
                            i += 2;
                        }
                        _ => {
                            // Copy one UTF-8 character.
                            let ch_len = text[i..].chars().next().map_or(1, char::len_utf8);
                            s.push_str(&text[i..i + ch_len]);
                            i += ch_len;
                        }
                    }
                }
                out.push((Tok::Str(s), loc(start_line)));
            }
            _ => {
                let start = i;
                while i < bytes.len()
                    && !matches!(
                        bytes[i],
                        b' ' | b'\t' | b'\r' | b'\n' | b'[' | b']' | b'"' | b'#' | b','
                    )
                {
                    i += 1;
                }
                let word = &text[start..i];
                if c.is_ascii_digit() || matches!(c, b'-' | b'+' | b'.') {
                    match (word.parse::<f64>(), word.parse::<f32>()) {
                        (Ok(d), Ok(s)) if d.is_finite() => out.push((Tok::Num(d, s), loc(line))),
                        _ => return Err(format!("{}: {word:?} is not a finite number", loc(line))),
                    }
                } else if c.is_ascii_alphabetic() {
                    out.push((Tok::Word(word.to_string()), loc(line)));
                } else {
                    return Err(format!(
                        "{}: unexpected character {:?}",
                        loc(line),
                        c as char
                    ));
                }
            }
        }
    }
    Ok(out)
}

/// One parameter's values.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    /// Numbers (double and single precision).
    Nums(Vec<(f64, f32)>),
    /// Strings.
    Strs(Vec<String>),
    /// Booleans.
    Bools(Vec<bool>),
}

/// One parameter: `"type name" values`.
#[derive(Debug)]
pub struct Param {
    /// Its type (`float`, `rgb`, `point3`, `texture`, …).
    pub ty: String,
    /// Its name.
    pub name: String,
    /// Its values.
    pub values: Values,
    /// Whether the reader used it (unused ones are warned about).
    pub used: std::cell::Cell<bool>,
}

/// One directive with its arguments and parameters.
#[derive(Debug)]
pub struct Stmt {
    /// The directive (`Shape`, `LookAt`, …).
    pub dir: String,
    /// Where it starts.
    pub loc: Loc,
    /// Positional arguments: strings and numbers (brackets flattened).
    pub args: Vec<Tok>,
    /// Parameters.
    pub params: Vec<Param>,
}

/// How many leading strings a directive takes before its parameter list (`None`: numbers
/// only, or nothing).
fn string_args(dir: &str) -> Option<usize> {
    Some(match dir {
        "Texture" => 3,
        "MediumInterface" => 2,
        "Camera" | "Film" | "Sampler" | "Integrator" | "Accelerator" | "PixelFilter"
        | "ColorSpace" | "Shape" | "Material" | "LightSource" | "AreaLightSource"
        | "MakeNamedMaterial" | "NamedMaterial" | "ObjectBegin" | "ObjectInstance" | "Include"
        | "Import" | "MakeNamedMedium" | "CoordinateSystem" | "CoordSysTransform" | "Attribute" => {
            1
        }
        "Option" => 0,
        _ => return None,
    })
}

/// Whether a bare word is a value rather than a directive.
fn is_value_word(w: &str) -> bool {
    w == "true" || w == "false"
}

/// Splits `toks` into statements; `Err` names `file:line` of a token where a directive was
/// expected, an unbalanced bracket or a malformed parameter list.
pub fn statements(toks: Vec<(Tok, Loc)>) -> Result<Vec<Stmt>, String> {
    let mut out = Vec::new();
    let mut it = toks.into_iter().peekable();
    while let Some((tok, loc)) = it.next() {
        let dir = match tok {
            Tok::Word(w) if !is_value_word(&w) => w,
            other => return Err(format!("{loc}: expected a directive, found {other}")),
        };
        // The statement's tokens: up to the next directive word.
        let mut body: Vec<(Tok, Loc)> = Vec::new();
        if dir == "ActiveTransform" {
            if let Some((Tok::Word(_), _)) = it.peek() {
                body.extend(it.next());
            }
        }
        while let Some((t, _)) = it.peek() {
            if matches!(t, Tok::Word(w) if !is_value_word(w)) {
                break;
            }
            body.extend(it.next());
        }
        out.push(statement(dir, loc, body)?);
    }
    Ok(out)
}

/// One statement from its body tokens.
fn statement(dir: String, loc: Loc, body: Vec<(Tok, Loc)>) -> Result<Stmt, String> {
    let mut args = Vec::new();
    let mut params = Vec::new();
    let mut i = 0;
    match string_args(&dir) {
        None => {
            // Numbers (and a bare word for ActiveTransform), brackets flattened.
            let mut depth = 0i32;
            for (t, l) in body {
                match t {
                    Tok::Open => depth += 1,
                    Tok::Close => {
                        depth -= 1;
                        if depth < 0 {
                            return Err(format!("{l}: {dir}: unbalanced ']'"));
                        }
                    }
                    t => args.push(t),
                }
            }
            if depth != 0 {
                return Err(format!("{loc}: {dir}: unbalanced '['"));
            }
            return Ok(Stmt {
                dir,
                loc,
                args,
                params,
            });
        }
        Some(n) => {
            while args.len() < n {
                match body.get(i) {
                    Some((Tok::Str(s), _)) => {
                        // A parameter declaration ends the positional strings early (the
                        // second name of MediumInterface is optional).
                        if dir == "MediumInterface" && !args.is_empty() && s.contains(' ') {
                            break;
                        }
                        args.push(Tok::Str(s.clone()));
                        i += 1;
                    }
                    Some((t, l)) if dir != "MediumInterface" || args.is_empty() => {
                        return Err(format!("{l}: {dir}: expected a quoted name, found {t}"))
                    }
                    None if dir != "MediumInterface" || args.is_empty() => {
                        return Err(format!("{loc}: {dir}: expected {n} quoted name(s)"))
                    }
                    _ => break,
                }
            }
        }
    }
    while i < body.len() {
        let (t, l) = &body[i];
        let decl = match t {
            Tok::Str(s) => s,
            t => {
                return Err(format!(
                    "{l}: {dir}: expected a parameter \"type name\", found {t}"
                ))
            }
        };
        let words: Vec<&str> = decl.split_whitespace().collect();
        if words.len() != 2 {
            return Err(format!(
                "{l}: {dir}: parameter declaration {decl:?} is not \"type name\""
            ));
        }
        i += 1;
        let mut vals: Vec<&Tok> = Vec::new();
        match body.get(i) {
            Some((Tok::Open, _)) => {
                i += 1;
                loop {
                    match body.get(i) {
                        Some((Tok::Close, _)) => {
                            i += 1;
                            break;
                        }
                        Some((Tok::Open, l2)) => {
                            return Err(format!("{l2}: {dir}: nested '[' in parameter {decl:?}"))
                        }
                        Some((t, _)) => {
                            vals.push(t);
                            i += 1;
                        }
                        None => return Err(format!("{l}: {dir}: parameter {decl:?}: missing ']'")),
                    }
                }
            }
            Some((Tok::Close, l2)) => return Err(format!("{l2}: {dir}: unbalanced ']'")),
            Some((t, _)) => {
                vals.push(t);
                i += 1;
            }
            None => return Err(format!("{l}: {dir}: parameter {decl:?} has no value")),
        }
        let values = if vals.iter().all(|t| matches!(t, Tok::Num(..))) {
            Values::Nums(
                vals.iter()
                    .map(|t| match t {
                        Tok::Num(d, s) => (*d, *s),
                        _ => unreachable!("checked above"),
                    })
                    .collect(),
            )
        } else if vals.iter().all(|t| matches!(t, Tok::Str(_))) {
            // `"bool b" "true"` is a boolean too.
            if words[0] == "bool" {
                let mut bools = Vec::new();
                for t in &vals {
                    match t {
                        Tok::Str(s) if s == "true" => bools.push(true),
                        Tok::Str(s) if s == "false" => bools.push(false),
                        t => {
                            return Err(format!(
                                "{l}: {dir}: parameter {decl:?}: {t} is not true or false"
                            ))
                        }
                    }
                }
                Values::Bools(bools)
            } else {
                Values::Strs(
                    vals.iter()
                        .map(|t| match t {
                            Tok::Str(s) => s.clone(),
                            _ => unreachable!("checked above"),
                        })
                        .collect(),
                )
            }
        } else if vals.iter().all(|t| matches!(t, Tok::Word(_))) {
            Values::Bools(
                vals.iter()
                    .map(|t| **t == Tok::Word("true".into()))
                    .collect(),
            )
        } else {
            return Err(format!(
                "{l}: {dir}: parameter {decl:?} mixes numbers, strings and booleans"
            ));
        };
        params.push(Param {
            ty: words[0].to_string(),
            name: words[1].to_string(),
            values,
            used: std::cell::Cell::new(false),
        });
    }
    Ok(Stmt {
        dir,
        loc,
        args,
        params,
    })
}
