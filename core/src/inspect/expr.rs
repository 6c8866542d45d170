//! The predicate language of `swarmfl bisect --until EXPR`.
//!
//! # Grammar
//!
//! ```text
//! expr    := or
//! or      := and ( "||" and )*
//! and     := cmp ( "&&" cmp )*
//! cmp     := sum ( ( "<" | "<=" | ">" | ">=" | "==" | "!=" ) sum )?
//! sum     := product ( ( "+" | "-" ) product )*
//! product := unary ( ( "*" | "/" ) unary )*
//! unary   := ( "!" | "-" ) unary | primary
//! primary := NUMBER | IDENT | IDENT "[" INTEGER "]" ( "." IDENT )? | "(" expr ")"
//! NUMBER  := digits [ "." digits ] [ ("e" | "E") [ "+" | "-" ] digits ]
//! IDENT   := letter ( letter | digit | "_" )*
//! ```
//!
//! Every value is an `f64`. Comparisons, `&&`, `||` and `!` give 1 (true) or 0 (false); a value
//! is true when it is non-zero and not NaN. A comparison with NaN (e.g. `loss` before the first
//! round closed) is false. Division by zero follows IEEE (inf or NaN).
//!
//! An expression is at most [`MAX_LEN_BYTES`] long and nests at most [`MAX_DEPTH`] parentheses
//! and unary operators deep: the parser recurses once per level, so without a bound a
//! command-line argument could overflow the stack before the log is even opened.
//!
//! The identifiers (checked when parsing) are those of [`IDENTS`], [`INDEXED`] (`balance[i]`)
//! and [`NODE_FIELDS`] (`node[i].height`); see [`super::BlockValues`] for their exact meaning.

use std::fmt;

/// The longest expression accepted, bytes. It also bounds the depth of the tree a chain of
/// binary operators builds (`1+1+...`), which evaluation and drop walk recursively.
pub const MAX_LEN_BYTES: usize = 4096;

/// The deepest nesting accepted: open parentheses plus pending unary operators (`!`, `-`).
pub const MAX_DEPTH: usize = 128;

/// The plain identifiers and what they mean.
pub const IDENTS: &[(&str, &str)] = &[
    ("height", "height of the block"),
    ("time", "the block's timestamp, simulated s"),
    (
        "round",
        "the contract's round (model version) after the block",
    ),
    (
        "loss",
        "paper metric of the last round closed on the chain up to the block (NaN before)",
    ),
    (
        "heldout_loss",
        "loss of the block's shared model on the held-out set",
    ),
    (
        "byzantine_tokens",
        "mean balance of the Byzantine robots, tokens (NaN without any)",
    ),
    (
        "honest_tokens",
        "mean balance of the honest robots, tokens (NaN without any)",
    ),
    (
        "byzantine_wealth",
        "byzantine_tokens plus the group's stakes in the current round, per robot",
    ),
    (
        "honest_wealth",
        "honest_tokens plus the group's stakes in the current round, per robot",
    ),
    (
        "byzantine_sum",
        "total balance of the Byzantine robots, tokens",
    ),
    ("honest_sum", "total balance of the honest robots, tokens"),
    (
        "byzantine_share",
        "byzantine_sum / (byzantine_sum + honest_sum), 0..1 (smart-then-collude switches above byzantine.switch_token_share)",
    ),
    ("accepted", "accepted submissions in the current round"),
    ("outliers", "outlier submissions in the current round"),
    (
        "pool",
        "tokens held by the contract (stakes and carried remainders)",
    ),
    ("robots", "number of robots"),
];

/// Identifiers indexed by a robot id: `balance[i]` (robot i's balance in tokens).
pub const INDEXED: &[(&str, &str)] = &[("balance", "robot i's balance after the block, tokens")];

/// Fields of `node[i]`: `node[i].height` (height of node i's head when the block was sealed).
pub const NODE_FIELDS: &[(&str, &str)] = &[(
    "height",
    "height of node i's head at the moment the block was sealed",
)];

/// A parsed expression.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    /// A number.
    Num(f64),
    /// A plain identifier.
    Ident(String),
    /// `name[index]`.
    Indexed(String, u32),
    /// `node[index].field`.
    Node(u32, String),
    /// `!e` or `-e`.
    Unary(UnOp, Box<Expr>),
    /// `a op b`.
    Binary(BinOp, Box<Expr>, Box<Expr>),
}

/// A unary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnOp {
    /// `!`
    Not,
    /// `-`
    Neg,
}

/// A binary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    /// `||`
    Or,
    /// `&&`
    And,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
}

impl BinOp {
    fn symbol(self) -> &'static str {
        match self {
            BinOp::Or => "||",
            BinOp::And => "&&",
            BinOp::Lt => "<",
            BinOp::Le => "<=",
            BinOp::Gt => ">",
            BinOp::Ge => ">=",
            BinOp::Eq => "==",
            BinOp::Ne => "!=",
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
        }
    }
}

/// A malformed expression: where (1-based column) and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("malformed expression at column {column}: {message}\n  {source_text}\n  {caret:>width$}", caret = "^", width = column)]
pub struct ParseError {
    /// 1-based column (in characters) of the offending token.
    pub column: usize,
    /// What was found and what was expected.
    pub message: String,
    /// The whole expression.
    pub source_text: String,
}

/// A value the expression names but the state cannot give (a robot id out of range).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct EvalError(pub String);

/// What an expression reads its identifiers from.
pub trait Env {
    /// The value of a plain identifier (one of [`IDENTS`]).
    fn ident(&self, name: &str) -> Result<f64, EvalError>;
    /// The value of `name[index]` (one of [`INDEXED`]).
    fn indexed(&self, name: &str, index: u32) -> Result<f64, EvalError>;
    /// The value of `node[index].field` (one of [`NODE_FIELDS`]).
    fn node(&self, index: u32, field: &str) -> Result<f64, EvalError>;
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Op(&'static str),
    End,
}

impl fmt::Display for Tok {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tok::Num(n) => write!(f, "number {n}"),
            Tok::Ident(s) => write!(f, "identifier `{s}`"),
            Tok::Op(s) => write!(f, "`{s}`"),
            Tok::End => write!(f, "the end of the expression"),
        }
    }
}

const OPS: &[&str] = &[
    "||", "&&", "<=", ">=", "==", "!=", "<", ">", "+", "-", "*", "/", "!", "(", ")", "[", "]", ".",
];

fn tokenize(src: &str) -> Result<Vec<(Tok, usize)>, ParseError> {
    let chars: Vec<char> = src.chars().collect();
    let err = |column: usize, message: String| ParseError {
        column,
        message,
        source_text: src.to_string(),
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let column = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() {
            let start = i;
            while i < chars.len() && chars[i].is_ascii_digit() {
                i += 1;
            }
            if i < chars.len()
                && chars[i] == '.'
                && chars.get(i + 1).is_some_and(char::is_ascii_digit)
            {
                i += 1;
                while i < chars.len() && chars[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    i = j;
                    while i < chars.len() && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                } else {
                    return Err(err(j + 1, "expected the exponent's digits".to_string()));
                }
            }
            let text: String = chars[start..i].iter().collect();
            let value = text
                .parse::<f64>()
                .map_err(|e| err(column, format!("bad number `{text}`: {e}")))?;
            out.push((Tok::Num(value), column));
        } else if c.is_ascii_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push((Tok::Ident(chars[start..i].iter().collect()), column));
        } else {
            let rest: String = chars[i..chars.len().min(i + 2)].iter().collect();
            let Some(op) = OPS.iter().find(|op| rest.starts_with(**op)) else {
                return Err(err(
                    column,
                    format!("unexpected character `{c}`; expected a number, an identifier, an operator or a parenthesis"),
                ));
            };
            out.push((Tok::Op(op), column));
            i += op.chars().count();
        }
    }
    out.push((Tok::End, chars.len() + 1));
    Ok(out)
}

struct Parser<'a> {
    toks: Vec<(Tok, usize)>,
    pos: usize,
    src: &'a str,
    /// Open parentheses plus pending unary operators at `pos`; at most [`MAX_DEPTH`].
    depth: usize,
}

impl Parser<'_> {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }

    fn column(&self) -> usize {
        self.toks[self.pos].1
    }

    fn error(&self, expected: &str) -> ParseError {
        ParseError {
            column: self.column(),
            message: format!("found {}, expected {expected}", self.peek()),
            source_text: self.src.to_string(),
        }
    }

    /// Enters one more level of nesting at the current token (an opening parenthesis or a
    /// unary operator), refusing to go deeper than [`MAX_DEPTH`].
    fn descend(&mut self) -> Result<(), ParseError> {
        if self.depth == MAX_DEPTH {
            return Err(ParseError {
                column: self.column(),
                message: format!(
                    "expression nests deeper than {MAX_DEPTH} (parentheses and `!`/`-` \
                     operators); expected at most {MAX_DEPTH} levels"
                ),
                source_text: self.src.to_string(),
            });
        }
        self.depth += 1;
        Ok(())
    }

    fn eat(&mut self, op: &str) -> bool {
        if matches!(self.peek(), Tok::Op(o) if *o == op) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    fn expect(&mut self, op: &str) -> Result<(), ParseError> {
        if self.eat(op) {
            Ok(())
        } else {
            Err(self.error(&format!("`{op}`")))
        }
    }

    fn binary_level(
        &mut self,
        ops: &[(&str, BinOp)],
        next: fn(&mut Self) -> Result<Expr, ParseError>,
        repeat: bool,
    ) -> Result<Expr, ParseError> {
        let mut left = next(self)?;
        loop {
            let Some(&(_, op)) = ops
                .iter()
                .find(|(s, _)| matches!(self.peek(), Tok::Op(o) if o == s))
            else {
                return Ok(left);
            };
            self.pos += 1;
            let right = next(self)?;
            left = Expr::Binary(op, Box::new(left), Box::new(right));
            if !repeat {
                if let Tok::Op(o) = self.peek() {
                    if ops.iter().any(|(s, _)| s == o) {
                        return Err(self.error(
                            "`&&`, `||`, `)` or the end (comparisons do not chain: use `&&`)",
                        ));
                    }
                }
                return Ok(left);
            }
        }
    }

    fn or(&mut self) -> Result<Expr, ParseError> {
        self.binary_level(&[("||", BinOp::Or)], Self::and, true)
    }

    fn and(&mut self) -> Result<Expr, ParseError> {
        self.binary_level(&[("&&", BinOp::And)], Self::cmp, true)
    }

    fn cmp(&mut self) -> Result<Expr, ParseError> {
        self.binary_level(
            &[
                ("<=", BinOp::Le),
                (">=", BinOp::Ge),
                ("==", BinOp::Eq),
                ("!=", BinOp::Ne),
                ("<", BinOp::Lt),
                (">", BinOp::Gt),
            ],
            Self::sum,
            false,
        )
    }

    fn sum(&mut self) -> Result<Expr, ParseError> {
        self.binary_level(&[("+", BinOp::Add), ("-", BinOp::Sub)], Self::product, true)
    }

    fn product(&mut self) -> Result<Expr, ParseError> {
        self.binary_level(&[("*", BinOp::Mul), ("/", BinOp::Div)], Self::unary, true)
    }

    fn unary(&mut self) -> Result<Expr, ParseError> {
        let op = match self.peek() {
            Tok::Op("!") => UnOp::Not,
            Tok::Op("-") => UnOp::Neg,
            _ => return self.primary(),
        };
        self.descend()?;
        self.pos += 1;
        let operand = self.unary()?;
        self.depth -= 1;
        Ok(Expr::Unary(op, Box::new(operand)))
    }

    fn index(&mut self) -> Result<u32, ParseError> {
        match *self.peek() {
            Tok::Num(n) if n >= 0.0 && n.fract() == 0.0 && n <= f64::from(u32::MAX) => {
                self.pos += 1;
                self.expect("]")?;
                Ok(n as u32)
            }
            _ => Err(self.error("a robot id (a non-negative integer)")),
        }
    }

    fn primary(&mut self) -> Result<Expr, ParseError> {
        match self.peek().clone() {
            Tok::Num(n) => {
                self.pos += 1;
                Ok(Expr::Num(n))
            }
            Tok::Op("(") => {
                self.descend()?;
                self.pos += 1;
                let e = self.or()?;
                self.expect(")")?;
                self.depth -= 1;
                Ok(e)
            }
            Tok::Ident(name) => {
                let column = self.column();
                self.pos += 1;
                let unknown = |what: String| ParseError {
                    column,
                    message: what,
                    source_text: self.src.to_string(),
                };
                if self.eat("[") {
                    let index = self.index()?;
                    if name == "node" {
                        self.expect(".")?;
                        let field = match self.peek().clone() {
                            Tok::Ident(f) if NODE_FIELDS.iter().any(|(n, _)| *n == f) => f,
                            _ => {
                                return Err(self.error(&format!(
                                    "a field of node[{index}]: {}",
                                    names(NODE_FIELDS)
                                )))
                            }
                        };
                        self.pos += 1;
                        Ok(Expr::Node(index, field))
                    } else if INDEXED.iter().any(|(n, _)| *n == name) {
                        Ok(Expr::Indexed(name, index))
                    } else {
                        Err(unknown(format!(
                            "`{name}` cannot be indexed; expected one of: node, {}",
                            names(INDEXED)
                        )))
                    }
                } else if IDENTS.iter().any(|(n, _)| *n == name) {
                    Ok(Expr::Ident(name))
                } else if name == "node" || INDEXED.iter().any(|(n, _)| *n == name) {
                    Err(self.error(&format!("`[` (`{name}` needs a robot id: `{name}[0]`)")))
                } else {
                    Err(unknown(format!(
                        "unknown identifier `{name}`; expected one of: {}, {}[i], node[i].height",
                        names(IDENTS),
                        names(INDEXED)
                    )))
                }
            }
            _ => Err(self.error("a number, an identifier, `-`, `!` or `(`")),
        }
    }
}

/// Refuses an expression longer than [`MAX_LEN_BYTES`], pointing at the first character past
/// the limit; the error shows only the accepted prefix, not the whole text.
fn check_length(src: &str) -> Result<(), ParseError> {
    if src.len() <= MAX_LEN_BYTES {
        return Ok(());
    }
    let mut end = MAX_LEN_BYTES;
    while !src.is_char_boundary(end) {
        end -= 1;
    }
    let prefix = &src[..end];
    Err(ParseError {
        column: prefix.chars().count() + 1,
        message: format!(
            "expression is {} bytes long; expected at most {MAX_LEN_BYTES}",
            src.len()
        ),
        source_text: format!("{prefix}..."),
    })
}

fn names(list: &[(&str, &str)]) -> String {
    list.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

impl Expr {
    /// Parses an expression (see the module docs for the grammar and the limits).
    pub fn parse(src: &str) -> Result<Expr, ParseError> {
        check_length(src)?;
        let mut p = Parser {
            toks: tokenize(src)?,
            pos: 0,
            src,
            depth: 0,
        };
        let e = p.or()?;
        if *p.peek() != Tok::End {
            return Err(p.error("an operator or the end of the expression"));
        }
        Ok(e)
    }

    /// Evaluates the expression against `env`.
    pub fn eval(&self, env: &dyn Env) -> Result<f64, EvalError> {
        let truth = |v: f64| v != 0.0 && !v.is_nan();
        let bool_value = |b: bool| if b { 1.0 } else { 0.0 };
        Ok(match self {
            Expr::Num(n) => *n,
            Expr::Ident(name) => env.ident(name)?,
            Expr::Indexed(name, i) => env.indexed(name, *i)?,
            Expr::Node(i, field) => env.node(*i, field)?,
            Expr::Unary(UnOp::Not, e) => bool_value(!truth(e.eval(env)?)),
            Expr::Unary(UnOp::Neg, e) => -e.eval(env)?,
            Expr::Binary(BinOp::And, a, b) => {
                bool_value(truth(a.eval(env)?) && truth(b.eval(env)?))
            }
            Expr::Binary(BinOp::Or, a, b) => bool_value(truth(a.eval(env)?) || truth(b.eval(env)?)),
            Expr::Binary(op, a, b) => {
                let (x, y) = (a.eval(env)?, b.eval(env)?);
                match op {
                    BinOp::Lt => bool_value(x < y),
                    BinOp::Le => bool_value(x <= y),
                    BinOp::Gt => bool_value(x > y),
                    BinOp::Ge => bool_value(x >= y),
                    BinOp::Eq => bool_value(x == y),
                    BinOp::Ne => bool_value(x != y),
                    BinOp::Add => x + y,
                    BinOp::Sub => x - y,
                    BinOp::Mul => x * y,
                    BinOp::Div => x / y,
                    BinOp::And | BinOp::Or => unreachable!("handled above"),
                }
            }
        })
    }

    /// Whether the expression holds (non-zero and not NaN) in `env`.
    pub fn holds(&self, env: &dyn Env) -> Result<bool, EvalError> {
        let v = self.eval(env)?;
        Ok(v != 0.0 && !v.is_nan())
    }

    /// The leaf values the expression reads, as `(text, value)`, in order of appearance and
    /// without repeats: what made it true.
    pub fn leaves(&self, env: &dyn Env) -> Vec<(String, f64)> {
        let mut out: Vec<(String, f64)> = Vec::new();
        self.collect_leaves(env, &mut out);
        out
    }

    /// Whether the expression reads `name` (a plain identifier).
    pub fn uses(&self, name: &str) -> bool {
        match self {
            Expr::Ident(n) => n == name,
            Expr::Num(_) | Expr::Indexed(..) | Expr::Node(..) => false,
            Expr::Unary(_, e) => e.uses(name),
            Expr::Binary(_, a, b) => a.uses(name) || b.uses(name),
        }
    }

    fn collect_leaves(&self, env: &dyn Env, out: &mut Vec<(String, f64)>) {
        let text = match self {
            Expr::Num(_) => return,
            Expr::Ident(n) => n.clone(),
            Expr::Indexed(n, i) => format!("{n}[{i}]"),
            Expr::Node(i, f) => format!("node[{i}].{f}"),
            Expr::Unary(_, e) => return e.collect_leaves(env, out),
            Expr::Binary(_, a, b) => {
                a.collect_leaves(env, out);
                b.collect_leaves(env, out);
                return;
            }
        };
        if out.iter().any(|(t, _)| *t == text) {
            return;
        }
        let value = self.eval(env).unwrap_or(f64::NAN);
        out.push((text, value));
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expr::Num(n) => write!(f, "{n}"),
            Expr::Ident(n) => write!(f, "{n}"),
            Expr::Indexed(n, i) => write!(f, "{n}[{i}]"),
            Expr::Node(i, field) => write!(f, "node[{i}].{field}"),
            Expr::Unary(UnOp::Not, e) => write!(f, "!{e}"),
            Expr::Unary(UnOp::Neg, e) => write!(f, "-{e}"),
            Expr::Binary(op, a, b) => write!(f, "({a} {} {b})", op.symbol()),
        }
    }
}

/// The grammar and identifiers, for `--help` texts.
pub fn help_text() -> String {
    let mut s = String::from(
        "Grammar: expr := or; or := and (\"||\" and)*; and := cmp (\"&&\" cmp)*; \
         cmp := sum ((< | <= | > | >= | == | !=) sum)?; sum := product ((+ | -) product)*; \
         product := unary ((* | /) unary)*; unary := (! | -) unary | primary; \
         primary := NUMBER | IDENT | balance[INT] | node[INT].height | ( expr ). \
         Values are f64; comparisons and logic give 1 or 0; anything compared with NaN is false. \
         Identifiers:",
    );
    for (n, d) in IDENTS {
        s.push_str(&format!(" `{n}` ({d});"));
    }
    for (n, d) in INDEXED {
        s.push_str(&format!(" `{n}[i]` ({d});"));
    }
    for (n, d) in NODE_FIELDS {
        s.push_str(&format!(" `node[i].{n}` ({d})."));
    }
    s
}
