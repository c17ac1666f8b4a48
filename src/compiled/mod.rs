//! Script laws compiled to native code: the one Rhai-to-native compiler that every stage's
//! user law goes through (stage 2 joint laws, stage 3 fracture criteria, stage 5 friction
//! laws). Each stage declares its law's [`Signature`] next to itself with `law_signature!`
//! (inputs and outputs by name): [`crate::joints::JOINT_LAW`],
//! [`crate::fracture::CRITERION`], [`crate::contact_interaction::FRICTION_LAW`].
//!
//! Interpreting Rhai per joint per step costs ~1.7 µs a call against ~10 ns for native code,
//! so a user's law — a plain Rhai function — is compiled once: its AST is walked into a tree
//! of `Send + Sync` closures over a fixed stack frame (no allocation per call), evaluated in
//! parallel by the stage.
//!
//! The function has two parameters, `fn my_law(j, p)`: `j.<input>` are the inputs of the
//! stage's signature (for a joint law `j.opening`, `j.slip`, `j.max_opening`, `j.max_slip`,
//! `j.size` and `j.damage`, the kinematics and history of the integration point);
//! `p.<name>` are the law's parameters (constants, folded in at compile time). It returns a
//! map of the signature's outputs (a joint law `#{ normal: σ, shear: τ, damage: D }`), or
//! the value alone when there is one output. The body may use numbers,
//! `let`, assignment, `if`/`else` (also as an expression), `return`, arithmetic
//! (`+ - * / % **`), comparisons, `&&`, `||`, `!`, and the functions `exp`, `ln`, `sqrt`,
//! `abs`, `min`, `max`, `sin`, `cos`, `tan`, `atan`, `floor`, `ceil`. Anything else is
//! refused with the construct and its line named.

use crate::params::Param;
use rhai::{Expr, Map, Position, Stmt, StmtBlock, AST};

/// The `params` key of every script law: constants folded in at compile time.
pub const PARAMS_KEY: Param = Param::other(
    "params",
    "map of numbers",
    "",
    "#{}",
    "The law's parameters, read as `p.<name>` (constants).",
);

/// The `source` key of every script law.
pub const SOURCE_KEY: Param = Param::other(
    "source",
    "string",
    "",
    "this script",
    "Where the function is defined: this script, or a stdlib module such as \"stdlib/joint_laws\" or \"stdlib/friction_laws\".",
);

/// Local variable slots available to a function (inputs included).
pub const MAX_SLOTS: usize = 48;
/// Largest number of outputs.
pub const MAX_OUTPUTS: usize = 4;

/// What a compiled function is: its kind (for messages), inputs and outputs.
#[derive(Clone, Copy, Debug)]
pub struct Signature {
    pub kind: &'static str,
    pub inputs: &'static [&'static str],
    pub outputs: &'static [&'static str],
}

/// Declares the signature of a stage's script law next to the stage: a struct of the named
/// inputs (their order is the slot order, written once), its `NAMES`, `to_slots()`, and a
/// [`Signature`] constant with the kind and the output names.
///
/// ```text
/// law_signature! {
///     /// Inputs of a friction law.
///     pub struct FrictionInputs { slip_rate, slip, pressure, normal_force, area, time, mu }
///     /// A contact friction law.
///     pub const FRICTION_LAW = "friction law" -> ["friction"];
/// }
/// ```
macro_rules! law_signature {
    (
        $(#[$smeta:meta])*
        $vis:vis struct $inputs:ident { $( $(#[$fmeta:meta])* $field:ident ),* $(,)? }
        $(#[$cmeta:meta])*
        $cvis:vis const $sig:ident = $kind:literal -> [ $($out:literal),* $(,)? ];
    ) => {
        $(#[$smeta])*
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        $vis struct $inputs { $( $(#[$fmeta])* pub $field: f64, )* }
        impl $inputs {
            /// Input names in slot order (`<first parameter>.<name>` in the script).
            pub const NAMES: &'static [&'static str] = &[$(stringify!($field)),*];
            /// The inputs in slot order.
            #[inline(always)]
            pub fn to_slots(&self) -> [f64; [$(stringify!($field)),*].len()] {
                [$(self.$field),*]
            }
        }
        $(#[$cmeta])*
        $cvis const $sig: $crate::compiled::Signature = $crate::compiled::Signature {
            kind: $kind,
            inputs: $inputs::NAMES,
            outputs: &[$($out),*],
        };
    };
}
pub(crate) use law_signature;

/// The evaluation frame: variable slots and the outputs.
pub struct Frame {
    pub v: [f64; MAX_SLOTS],
    pub out: [f64; MAX_OUTPUTS],
}

type ExprFn = Box<dyn Fn(&mut Frame) -> f64 + Send + Sync>;

/// A compiled expression: constants are folded at compile time and variables are read
/// inline by their parent node, so only composite expressions cost a call.
enum Node {
    Const(f64),
    Var(usize),
    Dyn(ExprFn),
}

impl Node {
    fn boxed(self) -> ExprFn {
        match self {
            Node::Const(c) => Box::new(move |_| c),
            Node::Var(i) => Box::new(move |f| f.v[i]),
            Node::Dyn(e) => e,
        }
    }
}

/// A binary node from `|x, y| body`, folded when both operands are constants.
macro_rules! bin {
    ($a:expr, $b:expr, |$x:ident, $y:ident| $body:expr) => {
        match ($a, $b) {
            (Node::Const($x), Node::Const($y)) => Node::Const($body),
            (Node::Var(i), Node::Var(k)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let ($x, $y) = (f.v[i], f.v[k]);
                $body
            })),
            (Node::Var(i), Node::Const($y)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let $x = f.v[i];
                $body
            })),
            (Node::Const($x), Node::Var(k)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let $y = f.v[k];
                $body
            })),
            (Node::Dyn(a), Node::Const($y)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let $x = a(f);
                $body
            })),
            (Node::Const($x), Node::Dyn(b)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let $y = b(f);
                $body
            })),
            (Node::Dyn(a), Node::Var(k)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let ($x, $y) = (a(f), f.v[k]);
                $body
            })),
            (Node::Var(i), Node::Dyn(b)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let ($x, $y) = (f.v[i], b(f));
                $body
            })),
            (Node::Dyn(a), Node::Dyn(b)) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let ($x, $y) = (a(f), b(f));
                $body
            })),
        }
    };
}

/// A unary node from `|x| body`, folded when the operand is a constant.
macro_rules! un {
    ($a:expr, |$x:ident| $body:expr) => {
        match $a {
            Node::Const($x) => Node::Const($body),
            Node::Var(i) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let $x = f.v[i];
                $body
            })),
            Node::Dyn(a) => Node::Dyn(Box::new(move |f: &mut Frame| {
                let $x = a(f);
                $body
            })),
        }
    };
}

#[inline(always)]
fn truth(b: bool) -> f64 {
    f64::from(u8::from(b))
}
/// Returns true when the law has returned (the outputs are set).
type StmtFn = Box<dyn Fn(&mut Frame) -> bool + Send + Sync>;

/// A compiled joint law or fracture criterion. Clones share the compiled body.
///
/// In a checkpoint a law is written as its key (kind, name and the parameters folded into it);
/// reading a checkpoint finds the law the restarted script compiled under that key (see
/// [`registry_key`]): compiled code cannot be stored, but the script that made it is run again.
#[derive(Clone)]
pub struct CompiledLaw {
    pub name: String,
    pub signature: Signature,
    body: std::sync::Arc<Vec<StmtFn>>,
    /// Kind, name and parameters: what makes two compilations the same law.
    key: String,
}

thread_local! {
    /// Every law compiled on this thread, by key: checkpoints name laws by key, and a restarted
    /// script compiles them again before the checkpoint is read.
    static REGISTRY: std::cell::RefCell<std::collections::HashMap<String, CompiledLaw>> =
        Default::default();
}

/// The key under which a law of `kind` compiled from function `name` with `params` is known.
fn registry_key(kind: &str, name: &str, params: &Map) -> String {
    format!("{kind} '{name}' {params:?}")
}

impl serde::Serialize for CompiledLaw {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.key)
    }
}

impl<'de> serde::Deserialize<'de> for CompiledLaw {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let key = String::deserialize(d)?;
        REGISTRY
            .with(|r| r.borrow().get(&key).cloned())
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "the model used the compiled {key}, which the script has not compiled this time (was the script changed?)"
                ))
            })
    }
}

impl std::fmt::Debug for CompiledLaw {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CompiledLaw({})", self.name)
    }
}

impl CompiledLaw {
    /// Evaluate with inputs in the signature's order; returns the outputs in the signature's
    /// order (for a law: normal, shear, damage). A function that ends without returning gives
    /// NaN, which stops the run as unstable.
    #[inline]
    pub fn evaluate<const N: usize>(&self, inputs: &[f64]) -> [f64; N] {
        self.evaluate_in(&mut Frame::new(), inputs)
    }

    /// [`Self::evaluate`] in a frame the caller reuses across calls: every slot is written
    /// (an input, or a `let` with its initialiser) before it is read, so the frame needs no
    /// clearing between calls.
    #[inline]
    pub fn evaluate_in<const N: usize>(&self, f: &mut Frame, inputs: &[f64]) -> [f64; N] {
        f.v[..inputs.len()].copy_from_slice(inputs);
        f.out = [f64::NAN; MAX_OUTPUTS];
        for s in self.body.iter() {
            if s(f) {
                break;
            }
        }
        std::array::from_fn(|i| f.out[i])
    }
}

impl Frame {
    pub fn new() -> Self {
        Frame {
            v: [0.0; MAX_SLOTS],
            out: [f64::NAN; MAX_OUTPUTS],
        }
    }
}

impl Default for Frame {
    fn default() -> Self {
        Self::new()
    }
}

/// Compile the script function `name` of `ast` as a function of signature `sig`.
pub fn compile_with(
    ast: &AST,
    name: &str,
    params: &Map,
    sig: Signature,
) -> Result<CompiledLaw, String> {
    let kind = sig.kind;
    let Some(def) = ast.iter_fn_def().find(|f| f.name == name) else {
        // Closures are stored as functions named anon$…: not the user's to name.
        let names: Vec<String> = ast
            .iter_functions()
            .filter(|f| !f.name.starts_with("anon$"))
            .map(|f| f.name.to_string())
            .collect();
        return Err(format!(
            "{kind}: no function '{name}' in the script; functions defined: {}",
            if names.is_empty() {
                "none".into()
            } else {
                names.join(", ")
            }
        ));
    };
    if def.params.len() != 2 {
        return Err(format!(
            "{kind} '{name}': the function must take two parameters (inputs, params), e.g. fn {name}(j, p); it takes {}",
            def.params.len()
        ));
    }
    // The body's top-level statements: the nodes at depth one of a walk over the AST that lie
    // inside the function's body span (script statements and other functions lie outside).
    let key = |p: Position| (p.line().unwrap_or(0), p.position().unwrap_or(0));
    let (start, end) = (key(def.body.start_position()), key(def.body.end_position()));
    let mut stmts: Vec<Stmt> = Vec::new();
    ast.walk(&mut |path: &[rhai::ASTNode]| {
        if let [rhai::ASTNode::Stmt(s)] = path {
            let at = key(s.position());
            if at >= start && at <= end {
                stmts.push((*s).clone());
            }
        }
        true
    });
    let mut c = Compiler {
        name,
        j: def.params[0].to_string(),
        p: def.params[1].to_string(),
        params,
        scopes: vec![Vec::new()],
        next: sig.inputs.len(),
        sig,
    };
    let body = c.statements(&stmts, true)?;
    let law = CompiledLaw {
        name: name.to_string(),
        signature: sig,
        body: std::sync::Arc::new(body),
        key: registry_key(kind, name, params),
    };
    REGISTRY.with(|r| r.borrow_mut().insert(law.key.clone(), law.clone()));
    Ok(law)
}

struct Compiler<'a> {
    name: &'a str,
    sig: Signature,
    j: String,
    p: String,
    params: &'a Map,
    scopes: Vec<Vec<(String, usize)>>,
    next: usize,
}

const ALLOWED: &str = "numbers, let, assignment, if/else, return, + - * / % **, comparisons, && || !, exp ln sqrt abs min max sin cos tan atan floor ceil";

/// A statement that is a value: an expression, or a function/operator call (Rhai stores
/// `a * b` as a call statement).
fn as_expr(s: &Stmt) -> Option<Expr> {
    match s {
        Stmt::Expr(e) => Some((**e).clone()),
        Stmt::FnCall(fc, pos) => Some(Expr::FnCall(fc.clone(), *pos)),
        _ => None,
    }
}

fn line(pos: Position) -> String {
    pos.line().map_or_else(|| "?".into(), |l| l.to_string())
}

impl Compiler<'_> {
    fn refuse<T>(&self, pos: Position, what: &str) -> Result<T, String> {
        Err(format!(
            "{} '{}': line {}: {what} is not supported in compiled functions (allowed: {ALLOWED}, {}.<input>, {}.<parameter>)",
            self.sig.kind,
            self.name,
            line(pos),
            self.j,
            self.p
        ))
    }

    fn lookup(&self, name: &str) -> Option<usize> {
        self.scopes
            .iter()
            .rev()
            .find_map(|s| s.iter().rev().find(|(n, _)| n == name).map(|(_, i)| *i))
    }

    fn block(&mut self, b: &StmtBlock, tail: bool) -> Result<Vec<StmtFn>, String> {
        self.statements(b.statements(), tail)
    }

    fn statements(&mut self, stmts: &[Stmt], tail: bool) -> Result<Vec<StmtFn>, String> {
        self.scopes.push(Vec::new());
        let n = stmts.len();
        let out = stmts
            .iter()
            .enumerate()
            .map(|(i, s)| self.stmt(s, tail && i + 1 == n))
            .collect();
        self.scopes.pop();
        out
    }

    fn stmt(&mut self, s: &Stmt, tail: bool) -> Result<StmtFn, String> {
        match s {
            Stmt::Noop(_) => Ok(Box::new(|_| false)),
            Stmt::Var(x, _, pos) => {
                let (ident, e, _) = &**x;
                let e = self.expr(e)?.boxed();
                if self.next >= MAX_SLOTS {
                    return self.refuse(
                        *pos,
                        &format!(
                            "more than {} local variables",
                            MAX_SLOTS - self.sig.inputs.len()
                        ),
                    );
                }
                let slot = self.next;
                self.next += 1;
                self.scopes
                    .last_mut()
                    .unwrap()
                    .push((ident.name.to_string(), slot));
                Ok(Box::new(move |f| {
                    f.v[slot] = e(f);
                    false
                }))
            }
            Stmt::Assignment(x) => {
                let (op, be) = &**x;
                let Expr::Variable(v, _, pos) = &be.lhs else {
                    return self.refuse(
                        be.lhs.position(),
                        "assignment to something other than a local variable",
                    );
                };
                let Some(slot) = self.lookup(&v.1) else {
                    return self.refuse(
                        *pos,
                        &format!("assignment to '{}' (only variables declared with let)", v.1),
                    );
                };
                let rhs = self.expr(&be.rhs)?;
                let rhs: ExprFn = match op.get_op_assignment_info() {
                    None => rhs.boxed(),
                    Some((.., syntax)) => self
                        .binary(syntax, Node::Var(slot), rhs, be.lhs.position())?
                        .boxed(),
                };
                Ok(Box::new(move |f| {
                    f.v[slot] = rhs(f);
                    false
                }))
            }
            Stmt::If(fc, _) => {
                let cond = self.expr(&fc.expr)?.boxed();
                let body = self.block(&fc.body, tail)?;
                let branch = self.block(&fc.branch, tail)?;
                Ok(Box::new(move |f| {
                    let run = if cond(f) != 0.0 { &body } else { &branch };
                    run.iter().any(|s| s(f))
                }))
            }
            Stmt::Return(Some(e), _, _) => self.ret(e),
            Stmt::Expr(e) if tail => self.ret(e),
            Stmt::FnCall(..) if tail => self.ret(&as_expr(s).unwrap()),
            Stmt::Block(b) => {
                let b = self.block(b, tail)?;
                Ok(Box::new(move |f| b.iter().any(|s| s(f))))
            }
            Stmt::Expr(e) => match &**e {
                Expr::Stmt(b) => {
                    let b = self.block(b, tail)?;
                    Ok(Box::new(move |f| b.iter().any(|s| s(f))))
                }
                other => self.refuse(other.position(), "an expression whose value is discarded"),
            },
            Stmt::While(..) | Stmt::Do(..) | Stmt::For(..) => self.refuse(s.position(), "a loop"),
            Stmt::FnCall(fc, pos) => {
                self.refuse(*pos, &format!("calling '{}' as a statement", fc.name))
            }
            other => self.refuse(other.position(), "this statement"),
        }
    }

    /// A return value: `#{ normal, shear, damage }`, or an `if` whose branches return one.
    /// A return value: a map with the signature's output keys (or, with a single output, a
    /// plain value), or an `if` whose branches return one.
    fn ret(&mut self, e: &Expr) -> Result<StmtFn, String> {
        let outputs = self.sig.outputs;
        let keys = outputs.join(", ");
        let slot_of = |this: &Self, key: &str, pos: Position| -> Result<usize, String> {
            outputs.iter().position(|&o| o == key).ok_or_else(|| {
                format!(
                    "{} '{}': line {}: the result map has key '{key}'; allowed keys: {keys}",
                    this.sig.kind,
                    this.name,
                    line(pos)
                )
            })
        };
        let missing = |this: &Self, pos: Position| {
            format!(
                "{} '{}': line {}: the result map needs the keys {keys}",
                this.sig.kind,
                this.name,
                line(pos)
            )
        };
        match e {
            Expr::Map(x, pos) => {
                let mut outs: Vec<Option<ExprFn>> = (0..outputs.len()).map(|_| None).collect();
                for (ident, value) in x.0.iter() {
                    let k = slot_of(self, ident.name.as_str(), ident.pos)?;
                    outs[k] = Some(self.expr(value)?.boxed());
                }
                let outs: Vec<ExprFn> = outs
                    .into_iter()
                    .collect::<Option<_>>()
                    .ok_or_else(|| missing(self, *pos))?;
                Ok(Box::new(move |f| {
                    for (k, o) in outs.iter().enumerate() {
                        f.out[k] = o(f);
                    }
                    true
                }))
            }
            Expr::Stmt(b)
                if outputs.len() > 1
                    || b.statements().len() != 1
                    || !matches!(b.statements()[0], Stmt::If(..)) =>
            {
                let b = self.block(b, true)?;
                Ok(Box::new(move |f| b.iter().any(|s| s(f))))
            }
            // An all-constant map literal, folded by Rhai's optimizer.
            Expr::DynamicConstant(d, pos) if d.is_map() => {
                let m = d.clone().cast::<Map>();
                let mut outs: Vec<Option<f64>> = vec![None; outputs.len()];
                for (key, value) in &m {
                    let k = slot_of(self, key.as_str(), *pos)?;
                    let v = value
                        .as_float()
                        .ok()
                        .or_else(|| value.as_int().ok().map(|i| i as f64))
                        .or_else(|| value.as_bool().ok().map(truth));
                    outs[k] = Some(v.ok_or_else(|| {
                        format!(
                            "{} '{}': line {}: result '{key}' is not a number",
                            self.sig.kind,
                            self.name,
                            line(*pos)
                        )
                    })?);
                }
                let outs: Vec<f64> = outs
                    .into_iter()
                    .collect::<Option<_>>()
                    .ok_or_else(|| missing(self, *pos))?;
                Ok(Box::new(move |f| {
                    f.out[..outs.len()].copy_from_slice(&outs);
                    true
                }))
            }
            // A single output may be returned as a plain value.
            other if outputs.len() == 1 => {
                let v = self.expr(other)?.boxed();
                Ok(Box::new(move |f| {
                    f.out[0] = v(f);
                    true
                }))
            }
            other => Err(format!(
                "{} '{}': line {}: the function must return #{{ {keys} }}",
                self.sig.kind,
                self.name,
                line(other.position())
            )),
        }
    }

    fn expr(&mut self, e: &Expr) -> Result<Node, String> {
        match e {
            Expr::FloatConstant(v, _) => Ok(Node::Const(**v)),
            Expr::IntegerConstant(i, _) => Ok(Node::Const(*i as f64)),
            Expr::BoolConstant(b, _) => Ok(Node::Const(truth(*b))),
            Expr::Variable(v, _, pos) => {
                let name = v.1.as_str();
                if let Some(slot) = self.lookup(name) {
                    return Ok(Node::Var(slot));
                }
                if name == self.j || name == self.p {
                    return self.refuse(
                        *pos,
                        &format!("using '{name}' as a value (read its fields: {name}.<name>)"),
                    );
                }
                self.refuse(
                    *pos,
                    &format!("the variable '{name}' (not a local of the law)"),
                )
            }
            Expr::Dot(be, _, pos) => self.dot(&be.lhs, &be.rhs, *pos),
            Expr::FnCall(fc, pos) => {
                if !fc.namespace.is_empty() {
                    return self.refuse(*pos, &format!("the module function '{}'", fc.name));
                }
                let args: Vec<Node> = fc
                    .args
                    .iter()
                    .map(|a| self.expr(a))
                    .collect::<Result<_, _>>()?;
                self.call(fc.name.as_str(), args, *pos)
            }
            Expr::And(v, _) | Expr::Or(v, _) => {
                let and = matches!(e, Expr::And(..));
                let parts: Vec<ExprFn> = v
                    .iter()
                    .map(|a| self.expr(a).map(Node::boxed))
                    .collect::<Result<_, _>>()?;
                Ok(Node::Dyn(if and {
                    Box::new(move |f| truth(parts.iter().all(|p| p(f) != 0.0)))
                } else {
                    Box::new(move |f| truth(parts.iter().any(|p| p(f) != 0.0)))
                }))
            }
            Expr::Stmt(b) => self.if_expr(b, e.position()),
            Expr::StringConstant(..) | Expr::InterpolatedString(..) | Expr::CharConstant(..) => {
                self.refuse(e.position(), "a string")
            }
            Expr::Array(..) => self.refuse(e.position(), "an array"),
            Expr::Map(..) => self.refuse(
                e.position(),
                "a map (only the returned result may be a map)",
            ),
            Expr::Index(..) => self.refuse(e.position(), "indexing"),
            Expr::MethodCall(fc, pos) => self.refuse(*pos, &format!("the method '{}'", fc.name)),
            other => self.refuse(other.position(), "this expression"),
        }
    }

    /// `if c { a } else { b }` used as a value: each branch may declare locals and ends with
    /// an expression.
    fn if_expr(&mut self, b: &StmtBlock, pos: Position) -> Result<Node, String> {
        let [Stmt::If(fc, _)] = b.statements() else {
            return self.refuse(pos, "a block used as a value");
        };
        let cond = self.expr(&fc.expr)?;
        let yes = self.value_block(&fc.body, pos)?;
        let no = self.value_block(&fc.branch, pos)?;
        Ok(match cond {
            Node::Const(c) => {
                if c != 0.0 {
                    yes
                } else {
                    no
                }
            }
            cond => {
                let (cond, yes, no) = (cond.boxed(), yes.boxed(), no.boxed());
                Node::Dyn(Box::new(
                    move |f| if cond(f) != 0.0 { yes(f) } else { no(f) },
                ))
            }
        })
    }

    fn value_block(&mut self, b: &StmtBlock, pos: Position) -> Result<Node, String> {
        let stmts = b.statements();
        let Some((last, init)) = stmts.split_last() else {
            return self.refuse(
                pos,
                "an if used as a value without an else branch ending in a value",
            );
        };
        let Some(last) = as_expr(last) else {
            return self.refuse(
                last.position(),
                "an if branch used as a value that does not end in a value",
            );
        };
        self.scopes.push(Vec::new());
        let init: Vec<StmtFn> = init
            .iter()
            .map(|s| self.stmt(s, false))
            .collect::<Result<_, _>>()?;
        let last = self.expr(&last)?;
        self.scopes.pop();
        if init.is_empty() {
            return Ok(last);
        }
        let last = last.boxed();
        Ok(Node::Dyn(Box::new(move |f| {
            for s in &init {
                s(f);
            }
            last(f)
        })))
    }

    fn dot(&mut self, lhs: &Expr, rhs: &Expr, pos: Position) -> Result<Node, String> {
        match (lhs, rhs) {
            (Expr::Variable(v, ..), Expr::Property(p, ppos)) if self.lookup(&v.1).is_none() => {
                let field = p.2.as_str();
                if v.1 == self.j {
                    match self.sig.inputs.iter().position(|&i| i == field) {
                        Some(slot) => Ok(Node::Var(slot)),
                        None => Err(format!(
                            "{} '{}': line {}: {}.{field} is not an input; inputs: {}",
                            self.sig.kind,
                            self.name,
                            line(*ppos),
                            self.j,
                            self.sig.inputs.join(", ")
                        )),
                    }
                } else if v.1 == self.p {
                    match self.params.get(field).and_then(|d| {
                        d.as_float()
                            .ok()
                            .or_else(|| d.as_int().ok().map(|i| i as f64))
                    }) {
                        Some(value) => Ok(Node::Const(value)),
                        None => {
                            let mut names: Vec<&str> =
                                self.params.keys().map(|k| k.as_str()).collect();
                            names.sort_unstable();
                            Err(format!("{} '{}': line {}: parameter '{field}' is not a number in the params; params: {}", self.sig.kind, self.name, line(*ppos), names.join(", ")))
                        }
                    }
                } else {
                    self.refuse(pos, &format!("the property '{}.{field}'", v.1))
                }
            }
            (obj, Expr::MethodCall(fc, mpos)) => {
                let mut args = vec![self.expr(obj)?];
                for a in fc.args.iter() {
                    args.push(self.expr(a)?);
                }
                self.call(fc.name.as_str(), args, *mpos)
            }
            _ => self.refuse(pos, "this property access"),
        }
    }

    fn binary(&self, op: &str, a: Node, b: Node, pos: Position) -> Result<Node, String> {
        Ok(match op {
            "+" => bin!(a, b, |x, y| x + y),
            "-" => bin!(a, b, |x, y| x - y),
            "*" => bin!(a, b, |x, y| x * y),
            "/" => bin!(a, b, |x, y| x / y),
            "%" => bin!(a, b, |x, y| x % y),
            "**" => bin!(a, b, |x, y| x.powf(y)),
            "<" => bin!(a, b, |x, y| truth(x < y)),
            "<=" => bin!(a, b, |x, y| truth(x <= y)),
            ">" => bin!(a, b, |x, y| truth(x > y)),
            ">=" => bin!(a, b, |x, y| truth(x >= y)),
            "==" => bin!(a, b, |x, y| truth(x == y)),
            "!=" => bin!(a, b, |x, y| truth(x != y)),
            "min" => bin!(a, b, |x, y| x.min(y)),
            "max" => bin!(a, b, |x, y| x.max(y)),
            "atan" => bin!(a, b, |x, y| x.atan2(y)),
            _ => {
                return self.refuse(
                    pos,
                    &format!("the operator or function '{op}' with two arguments"),
                )
            }
        })
    }

    fn call(&self, name: &str, mut args: Vec<Node>, pos: Position) -> Result<Node, String> {
        match args.len() {
            1 => {
                let a = args.pop().unwrap();
                Ok(match name {
                    "-" => un!(a, |x| -x),
                    "+" | "to_float" => a,
                    "!" => un!(a, |x| truth(x == 0.0)),
                    "exp" => un!(a, |x| x.exp()),
                    "ln" => un!(a, |x| x.ln()),
                    "sqrt" => un!(a, |x| x.sqrt()),
                    "abs" => un!(a, |x| x.abs()),
                    "sin" => un!(a, |x| x.sin()),
                    "cos" => un!(a, |x| x.cos()),
                    "tan" => un!(a, |x| x.tan()),
                    "atan" => un!(a, |x| x.atan()),
                    "floor" => un!(a, |x| x.floor()),
                    "ceil" => un!(a, |x| x.ceil()),
                    _ => return self.refuse(pos, &format!("the function '{name}'")),
                })
            }
            2 => {
                let b = args.pop().unwrap();
                let a = args.pop().unwrap();
                self.binary(name, a, b, pos)
            }
            n => self.refuse(pos, &format!("the function '{name}' with {n} arguments")),
        }
    }
}
