//! A recursive-descent parser for the openCypher subset the engine runs.

use super::ast::*;
use super::lexer::{Tok, Token, lex};
use super::value::Val;
use super::{Pos, QueryError};

/// Parses one statement.
pub(crate) fn parse(src: &str) -> Result<Statement, QueryError> {
    let toks = lex(src)?;
    let mut p = Parser {
        src,
        toks,
        i: 0,
        depth: 0,
        chain: 0,
    };
    p.statement()
}

struct Parser<'a> {
    src: &'a str,
    toks: Vec<Token>,
    i: usize,
    depth: u32,
    chain: u32,
}

/// Nesting of parentheses, lists and calls (each level costs the parser a dozen frames).
const MAX_DEPTH: u32 = 40;
/// Depth of an expression tree, operators in a chain included (evaluation recurses through it).
const MAX_TREE_DEPTH: u32 = 64;
/// Operators in a row at one nesting level (bounds the parser's work before the depth check).
const MAX_CHAIN: u32 = 4096;

const RESERVED: &[&str] = &[
    "match",
    "optional",
    "where",
    "return",
    "with",
    "create",
    "merge",
    "set",
    "remove",
    "delete",
    "detach",
    "unwind",
    "union",
    "order",
    "skip",
    "limit",
    "call",
    "yield",
    "as",
    "and",
    "or",
    "xor",
    "not",
    "in",
    "is",
    "case",
    "when",
    "then",
    "else",
    "end",
    "on",
    "distinct",
    "starts",
    "ends",
    "contains",
    "asc",
    "desc",
    "ascending",
    "descending",
    "by",
];

type R<T> = Result<T, QueryError>;

impl Parser<'_> {
    fn tok(&self) -> &Tok {
        &self.toks[self.i].tok
    }
    fn tok_at(&self, k: usize) -> &Tok {
        let j = (self.i + k).min(self.toks.len() - 1);
        &self.toks[j].tok
    }
    fn pos(&self) -> Pos {
        self.toks[self.i].pos
    }
    fn advance(&mut self) -> Token {
        let t = self.toks[self.i].clone();
        if self.i + 1 < self.toks.len() {
            self.i += 1;
        }
        t
    }
    fn prev_end(&self) -> usize {
        if self.i == 0 {
            0
        } else {
            self.toks[self.i - 1].end
        }
    }
    fn is_kw(&self, k: &str) -> bool {
        matches!(self.tok(), Tok::Ident(s) if s.eq_ignore_ascii_case(k))
    }
    fn is_kw_at(&self, off: usize, k: &str) -> bool {
        matches!(self.tok_at(off), Tok::Ident(s) if s.eq_ignore_ascii_case(k))
    }
    fn eat_kw(&mut self, k: &str) -> bool {
        if self.is_kw(k) {
            self.advance();
            true
        } else {
            false
        }
    }
    fn is_sym(&self, s: &str) -> bool {
        matches!(self.tok(), Tok::Sym(x) if *x == s)
    }
    fn eat_sym(&mut self, s: &str) -> bool {
        if self.is_sym(s) {
            self.advance();
            true
        } else {
            false
        }
    }
    fn describe(&self) -> String {
        match self.tok() {
            Tok::Eof => "end of input".into(),
            Tok::Ident(s) => format!("'{s}'"),
            Tok::Quoted(s) => format!("`{s}`"),
            Tok::Int(i) => format!("{i}"),
            Tok::Float(f) => format!("{f}"),
            Tok::Str(s) => format!("'{s}'"),
            Tok::Param(s) => format!("${s}"),
            Tok::Sym(s) => format!("'{s}'"),
        }
    }
    fn err<T>(&self, what: &str) -> R<T> {
        Err(QueryError::syntax(
            "UnexpectedSyntax",
            format!("expected {what} but found {}", self.describe()),
            Some(self.pos()),
        ))
    }
    fn expect_sym(&mut self, s: &str) -> R<()> {
        if self.eat_sym(s) {
            Ok(())
        } else {
            self.err(&format!("'{s}'"))
        }
    }
    fn expect_kw(&mut self, k: &str) -> R<()> {
        if self.eat_kw(k) { Ok(()) } else { self.err(k) }
    }
    /// A name: identifier (keywords allowed where unambiguous) or backtick-quoted.
    fn name(&mut self) -> R<String> {
        match self.tok().clone() {
            Tok::Ident(s) | Tok::Quoted(s) => {
                self.advance();
                Ok(s)
            }
            _ => self.err("a name"),
        }
    }
    /// A variable name: not a reserved word unless quoted.
    fn var_name(&mut self) -> R<String> {
        match self.tok().clone() {
            Tok::Ident(s) if !RESERVED.contains(&s.to_ascii_lowercase().as_str()) => {
                self.advance();
                Ok(s)
            }
            Tok::Quoted(s) => {
                self.advance();
                Ok(s)
            }
            _ => self.err("a variable name"),
        }
    }
    fn at_var(&self) -> bool {
        match self.tok() {
            Tok::Ident(s) => !RESERVED.contains(&s.to_ascii_lowercase().as_str()),
            Tok::Quoted(_) => true,
            _ => false,
        }
    }

    fn statement(&mut self) -> R<Statement> {
        let explain = self.eat_kw("explain");
        let profile = !explain && self.eat_kw("profile");
        let mut parts = vec![self.single_query()?];
        let mut union_all = Vec::new();
        while self.eat_kw("union") {
            union_all.push(self.eat_kw("all"));
            parts.push(self.single_query()?);
        }
        self.eat_sym(";");
        if !matches!(self.tok(), Tok::Eof) {
            return self.err("a clause or end of input");
        }
        Ok(Statement {
            explain,
            profile,
            parts,
            union_all,
        })
    }

    fn single_query(&mut self) -> R<SingleQuery> {
        let mut clauses = Vec::new();
        let mut positions = Vec::new();
        loop {
            if matches!(self.tok(), Tok::Eof) || self.is_kw("union") || self.is_sym(";") {
                break;
            }
            positions.push(self.pos());
            clauses.push(self.clause()?);
        }
        if clauses.is_empty() {
            return self.err("a clause (MATCH, CREATE, RETURN, ...)");
        }
        Ok(SingleQuery { clauses, positions })
    }

    fn clause(&mut self) -> R<Clause> {
        let pos = self.pos();
        if self.is_kw("optional") && self.is_kw_at(1, "match") {
            self.advance();
            self.advance();
            return self.match_rest(true);
        }
        if self.eat_kw("match") {
            return self.match_rest(false);
        }
        if self.eat_kw("unwind") {
            let expr = self.expr()?;
            self.expect_kw("as")?;
            let var = self.var_name()?;
            return Ok(Clause::Unwind { expr, var });
        }
        if self.eat_kw("with") {
            return Ok(Clause::With(self.projection(true, pos)?));
        }
        if self.eat_kw("return") {
            return Ok(Clause::Return(self.projection(false, pos)?));
        }
        if self.eat_kw("create") {
            return Ok(Clause::Create(self.patterns()?));
        }
        if self.eat_kw("merge") {
            let pattern = self.path_pattern()?;
            let mut on_create = Vec::new();
            let mut on_match = Vec::new();
            while self.is_kw("on") {
                self.advance();
                if self.eat_kw("create") {
                    self.expect_kw("set")?;
                    on_create.extend(self.set_items()?);
                } else if self.eat_kw("match") {
                    self.expect_kw("set")?;
                    on_match.extend(self.set_items()?);
                } else {
                    return self.err("CREATE or MATCH after ON");
                }
            }
            return Ok(Clause::Merge {
                pattern,
                on_create,
                on_match,
            });
        }
        if self.eat_kw("set") {
            return Ok(Clause::Set(self.set_items()?));
        }
        if self.eat_kw("remove") {
            let mut items = Vec::new();
            loop {
                let ipos = self.pos();
                let target = self.postfix_expr()?;
                match target {
                    Expr::Prop(t, key) => items.push(RemoveItem::Prop { target: *t, key }),
                    Expr::HasLabels(v, labels) => {
                        let var = label_target(*v, ipos, "REMOVE")?;
                        items.push(RemoveItem::Labels {
                            var,
                            labels,
                            pos: ipos,
                        });
                    }
                    _ => {
                        return Err(QueryError::syntax(
                            "UnexpectedSyntax",
                            "REMOVE takes `x.key` or `x:Label`",
                            Some(ipos),
                        ));
                    }
                }
                if !self.eat_sym(",") {
                    break;
                }
            }
            return Ok(Clause::Remove(items));
        }
        if self.is_kw("detach") && self.is_kw_at(1, "delete") {
            self.advance();
            self.advance();
            return Ok(Clause::Delete {
                detach: true,
                exprs: self.expr_list()?,
            });
        }
        if self.eat_kw("delete") {
            return Ok(Clause::Delete {
                detach: false,
                exprs: self.expr_list()?,
            });
        }
        if self.eat_kw("call") {
            let mut name = self.name()?;
            while self.eat_sym(".") {
                name.push('.');
                name.push_str(&self.name()?);
            }
            let mut args = Vec::new();
            if self.eat_sym("(") {
                if !self.is_sym(")") {
                    args = self.expr_list()?;
                }
                self.expect_sym(")")?;
            }
            let mut yields = None;
            let mut where_ = None;
            if self.eat_kw("yield") {
                let mut ys = Vec::new();
                if self.eat_sym("*") {
                    ys.push(("*".to_string(), "*".to_string()));
                } else {
                    loop {
                        let n = self.name()?;
                        let alias = if self.eat_kw("as") {
                            self.var_name()?
                        } else {
                            n.clone()
                        };
                        ys.push((n, alias));
                        if !self.eat_sym(",") {
                            break;
                        }
                    }
                }
                yields = Some(ys);
                if self.eat_kw("where") {
                    where_ = Some(self.expr()?);
                }
            }
            return Ok(Clause::Call {
                name,
                args,
                yields,
                where_,
                pos,
            });
        }
        self.err("a clause (MATCH, OPTIONAL MATCH, WITH, RETURN, UNWIND, CREATE, MERGE, SET, REMOVE, DELETE, CALL)")
    }

    fn match_rest(&mut self, optional: bool) -> R<Clause> {
        let patterns = self.patterns()?;
        let where_ = if self.eat_kw("where") {
            Some(self.expr()?)
        } else {
            None
        };
        Ok(Clause::Match {
            optional,
            patterns,
            where_,
        })
    }

    fn expr_list(&mut self) -> R<Vec<Expr>> {
        let mut v = vec![self.expr()?];
        while self.eat_sym(",") {
            v.push(self.expr()?);
        }
        Ok(v)
    }

    fn set_items(&mut self) -> R<Vec<SetItem>> {
        let mut items = Vec::new();
        loop {
            let ipos = self.pos();
            if self.at_var() && (matches!(self.tok_at(1), Tok::Sym("=") | Tok::Sym("+="))) {
                let var = self.var_name()?;
                let merge = self.is_sym("+=");
                self.advance();
                let value = self.expr()?;
                items.push(if merge {
                    SetItem::Merge {
                        var,
                        value,
                        pos: ipos,
                    }
                } else {
                    SetItem::Replace {
                        var,
                        value,
                        pos: ipos,
                    }
                });
            } else {
                let target = self.postfix_expr()?;
                match target {
                    Expr::Prop(t, key) => {
                        self.expect_sym("=")?;
                        let value = self.expr()?;
                        items.push(SetItem::Prop {
                            target: *t,
                            key,
                            value,
                        });
                    }
                    Expr::HasLabels(v, labels) => {
                        let var = label_target(*v, ipos, "SET")?;
                        items.push(SetItem::Labels {
                            var,
                            labels,
                            pos: ipos,
                        });
                    }
                    _ => {
                        return Err(QueryError::syntax(
                            "UnexpectedSyntax",
                            "SET takes `x.key = v`, `x = map`, `x += map` or `x:Label`",
                            Some(ipos),
                        ));
                    }
                }
            }
            if !self.eat_sym(",") {
                break;
            }
        }
        Ok(items)
    }

    fn projection(&mut self, is_with: bool, pos: Pos) -> R<Projection> {
        let distinct = self.eat_kw("distinct");
        let mut star = false;
        let mut items = Vec::new();
        if self.eat_sym("*") {
            star = true;
            if !self.eat_sym(",") {
                return self.projection_tail(distinct, star, items, is_with, pos);
            }
        }
        loop {
            let ipos = self.pos();
            let start = self.toks[self.i].start;
            let expr = self.expr()?;
            let end = self.prev_end();
            let text = self.src[start..end].trim().to_string();
            let (name, aliased) = if self.eat_kw("as") {
                (self.var_name()?, true)
            } else {
                (text.clone(), false)
            };
            items.push(Item {
                expr,
                text,
                name,
                aliased,
                pos: ipos,
            });
            if !self.eat_sym(",") {
                break;
            }
        }
        self.projection_tail(distinct, star, items, is_with, pos)
    }

    fn projection_tail(
        &mut self,
        distinct: bool,
        star: bool,
        items: Vec<Item>,
        is_with: bool,
        pos: Pos,
    ) -> R<Projection> {
        let mut order = Vec::new();
        if self.is_kw("order") {
            self.advance();
            self.expect_kw("by")?;
            loop {
                let start = self.toks[self.i].start;
                let e = self.expr()?;
                let text = self.src[start..self.prev_end()].trim().to_string();
                let asc = if self.eat_kw("desc") || self.eat_kw("descending") {
                    false
                } else {
                    let _ = self.eat_kw("asc") || self.eat_kw("ascending");
                    true
                };
                order.push((e, asc, text));
                if !self.eat_sym(",") {
                    break;
                }
            }
        }
        let skip = if self.eat_kw("skip") {
            Some(self.expr()?)
        } else {
            None
        };
        let limit = if self.eat_kw("limit") {
            Some(self.expr()?)
        } else {
            None
        };
        let where_ = if is_with && self.eat_kw("where") {
            Some(self.expr()?)
        } else {
            None
        };
        Ok(Projection {
            distinct,
            star,
            items,
            order,
            skip,
            limit,
            where_,
            pos,
        })
    }

    fn patterns(&mut self) -> R<Vec<PathPattern>> {
        let mut v = vec![self.path_pattern()?];
        while self.eat_sym(",") {
            v.push(self.path_pattern()?);
        }
        Ok(v)
    }

    fn path_pattern(&mut self) -> R<PathPattern> {
        let pos = self.pos();
        let mut var = None;
        if self.at_var() && matches!(self.tok_at(1), Tok::Sym("=")) {
            var = Some(self.var_name()?);
            self.advance();
        }
        // `shortestPath((a)-[*]-(b))` and `allShortestPaths(...)`
        let shortest = if matches!(self.tok_at(1), Tok::Sym("(")) && self.is_kw("shortestPath") {
            Some(Shortest::One)
        } else if matches!(self.tok_at(1), Tok::Sym("(")) && self.is_kw("allShortestPaths") {
            Some(Shortest::All)
        } else {
            None
        };
        if shortest.is_some() {
            self.advance();
            self.expect_sym("(")?;
        }
        // `p = (a)-->(b)` with parentheses around the whole pattern is not supported
        let start = self.node_pattern()?;
        let mut steps = Vec::new();
        while self.is_sym("-") || self.is_sym("<-") {
            let rel = self.rel_pattern()?;
            let node = self.node_pattern()?;
            steps.push((rel, node));
        }
        if let Some(kind) = shortest {
            self.expect_sym(")")?;
            let name = match kind {
                Shortest::One => "shortestPath",
                Shortest::All => "allShortestPaths",
            };
            if steps.len() != 1 {
                return Err(QueryError::syntax(
                    "InvalidShortestPath",
                    format!(
                        "{name} takes a pattern with exactly one relationship, such as (a)-[:LANE*]-(b)"
                    ),
                    Some(pos),
                ));
            }
            if let Some((Some(lo), _)) = steps[0].0.range
                && lo > 1
            {
                return Err(QueryError::syntax(
                    "InvalidShortestPath",
                    format!("{name}'s relationship may start at 0 or 1 hops, not {lo}"),
                    Some(steps[0].0.pos),
                ));
            }
        }
        Ok(PathPattern {
            var,
            start,
            steps,
            shortest,
            pos,
        })
    }

    fn node_pattern(&mut self) -> R<NodePat> {
        let pos = self.pos();
        self.expect_sym("(")?;
        let var = if self.at_var() {
            Some(self.var_name()?)
        } else {
            None
        };
        let mut labels = Vec::new();
        while self.eat_sym(":") {
            labels.push(self.name()?);
        }
        let props = self.pattern_props()?;
        self.expect_sym(")")?;
        Ok(NodePat {
            var,
            labels,
            props,
            pos,
        })
    }

    fn pattern_props(&mut self) -> R<Option<Expr>> {
        if self.is_sym("{") {
            Ok(Some(self.map_literal()?))
        } else if let Tok::Param(p) = self.tok().clone() {
            let pos = self.pos();
            self.advance();
            Ok(Some(Expr::Param(p, pos)))
        } else {
            Ok(None)
        }
    }

    fn rel_pattern(&mut self) -> R<RelPat> {
        let pos = self.pos();
        let left = self.eat_sym("<-");
        if !left {
            self.expect_sym("-")?;
        }
        let mut var = None;
        let mut types = Vec::new();
        let mut props = None;
        let mut range = None;
        if self.eat_sym("[") {
            if self.at_var() {
                var = Some(self.var_name()?);
            }
            if self.eat_sym(":") {
                types.push(self.name()?);
                while self.eat_sym("|") {
                    self.eat_sym(":");
                    types.push(self.name()?);
                }
            }
            if self.eat_sym("*") {
                let lo = self.opt_uint()?;
                if self.eat_sym("..") {
                    let hi = self.opt_uint()?;
                    range = Some((lo, hi));
                } else {
                    range = Some((lo, lo));
                    if lo.is_none() {
                        range = Some((None, None));
                    }
                }
            }
            props = self.pattern_props()?;
            self.expect_sym("]")?;
        }
        let right = if self.eat_sym("->") {
            true
        } else {
            self.expect_sym("-")?;
            false
        };
        let dir = match (left, right) {
            (true, false) => Dir::In,
            (false, true) => Dir::Out,
            (false, false) => Dir::Both,
            // `<-->` is an undirected relationship, like `--`
            (true, true) => Dir::Both,
        };
        Ok(RelPat {
            var,
            types,
            dir,
            props,
            range,
            pos,
        })
    }

    /// `EXISTS { ... }` / `COUNT { ... }`: `[MATCH] patterns [WHERE pred]` inside braces.
    fn subquery_expr(&mut self, count: bool) -> R<Expr> {
        let pos = self.pos();
        self.advance();
        self.expect_sym("{")?;
        self.eat_kw("match");
        let patterns = self.patterns()?;
        let where_ = if self.eat_kw("where") {
            Some(Box::new(self.expr()?))
        } else {
            None
        };
        if !self.is_sym("}") {
            let what = if count { "COUNT" } else { "EXISTS" };
            return Err(QueryError::syntax(
                "UnexpectedSyntax",
                format!(
                    "{what} {{ }} takes patterns (MATCH optional) and an optional WHERE; expected '}}'"
                ),
                Some(self.pos()),
            ));
        }
        self.advance();
        if patterns.iter().any(|p| p.shortest.is_some()) {
            return Err(QueryError::syntax(
                "InvalidShortestPath",
                "shortestPath is not allowed inside EXISTS { } or COUNT { }",
                Some(pos),
            ));
        }
        Ok(Expr::Subquery {
            count,
            patterns,
            where_,
            pos,
        })
    }

    fn opt_uint(&mut self) -> R<Option<u64>> {
        if let Tok::Int(i) = *self.tok() {
            self.advance();
            Ok(Some(i))
        } else {
            Ok(None)
        }
    }

    fn map_literal(&mut self) -> R<Expr> {
        self.expect_sym("{")?;
        let mut entries: Vec<(String, Expr)> = Vec::new();
        if !self.is_sym("}") {
            loop {
                let key = self.name()?;
                self.expect_sym(":")?;
                let v = self.expr()?;
                entries.push((key, v));
                if !self.eat_sym(",") {
                    break;
                }
            }
        }
        self.expect_sym("}")?;
        Ok(Expr::Map(entries))
    }

    // ---- expressions ----

    pub(crate) fn expr(&mut self) -> R<Expr> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(QueryError::syntax(
                "UnexpectedSyntax",
                "expression nested too deeply",
                Some(self.pos()),
            ));
        }
        let chain = self.chain;
        let pos = self.pos();
        let r = self.or_expr();
        self.depth -= 1;
        self.chain = chain;
        // the tree's real depth bounds every recursion over it (checks, evaluation)
        if self.depth == 0
            && let Ok(e) = &r
            && e.depth() > MAX_TREE_DEPTH as usize
        {
            return Err(QueryError::syntax(
                "UnexpectedSyntax",
                format!(
                    "expression too deep (more than {MAX_TREE_DEPTH} levels); split it or use IN [...]"
                ),
                Some(pos),
            ));
        }
        r
    }

    /// One more operator in a row (`a + b + c` nests to the left); bounds the parser's work
    /// before the depth check.
    fn grow(&mut self) -> R<()> {
        self.chain += 1;
        if self.chain > MAX_CHAIN {
            return Err(QueryError::syntax(
                "UnexpectedSyntax",
                format!("expression too long (more than {MAX_CHAIN} operators in a row)"),
                Some(self.pos()),
            ));
        }
        Ok(())
    }

    fn or_expr(&mut self) -> R<Expr> {
        self.left_chain(&[("or", BinOp::Or)], Self::xor_expr)
    }
    fn xor_expr(&mut self) -> R<Expr> {
        self.left_chain(&[("xor", BinOp::Xor)], Self::and_expr)
    }
    fn and_expr(&mut self) -> R<Expr> {
        self.left_chain(&[("and", BinOp::And)], Self::not_expr)
    }
    fn not_expr(&mut self) -> R<Expr> {
        if self.eat_kw("not") {
            self.depth += 1;
            if self.depth > MAX_DEPTH {
                return Err(QueryError::syntax(
                    "UnexpectedSyntax",
                    "expression nested too deeply",
                    Some(self.pos()),
                ));
            }
            let e = self.not_expr();
            self.depth -= 1;
            return Ok(Expr::Not(Box::new(e?)));
        }
        self.comparison()
    }
    fn comparison(&mut self) -> R<Expr> {
        let first = self.predicate_expr()?;
        let mut operands = vec![first];
        let mut ops = Vec::new();
        loop {
            let op = match self.tok() {
                Tok::Sym("=") => BinOp::Eq,
                Tok::Sym("<>") | Tok::Sym("!=") => BinOp::Ne,
                Tok::Sym("<") => BinOp::Lt,
                Tok::Sym("<=") => BinOp::Le,
                Tok::Sym(">") => BinOp::Gt,
                Tok::Sym(">=") => BinOp::Ge,
                Tok::Sym("<-") => {
                    // `a<-1` lexes as `<-`: it is `a < -1`
                    self.advance();
                    self.grow()?;
                    let rhs = self.predicate_expr()?;
                    ops.push(BinOp::Lt);
                    operands.push(Expr::Neg(Box::new(rhs)));
                    continue;
                }
                _ => break,
            };
            self.advance();
            self.grow()?;
            ops.push(op);
            operands.push(self.predicate_expr()?);
        }
        if ops.is_empty() {
            Ok(operands.pop().unwrap_or(Expr::Lit(Val::Null)))
        } else if ops.len() == 1 {
            let r = operands.pop().unwrap_or(Expr::Lit(Val::Null));
            let l = operands.pop().unwrap_or(Expr::Lit(Val::Null));
            Ok(Expr::Bin(ops[0], Box::new(l), Box::new(r)))
        } else {
            Ok(Expr::Chain(operands, ops))
        }
    }
    fn predicate_expr(&mut self) -> R<Expr> {
        let mut l = self.add_expr()?;
        loop {
            if self.is_kw("is") {
                self.grow()?;
                self.advance();
                let neg = self.eat_kw("not");
                self.expect_kw("null")?;
                l = Expr::IsNull(Box::new(l), neg);
            } else if self.is_kw("in") {
                self.grow()?;
                self.advance();
                let r = self.add_expr()?;
                l = Expr::Bin(BinOp::In, Box::new(l), Box::new(r));
            } else if self.is_kw("starts") && self.is_kw_at(1, "with") {
                self.grow()?;
                self.advance();
                self.advance();
                let r = self.add_expr()?;
                l = Expr::Bin(BinOp::StartsWith, Box::new(l), Box::new(r));
            } else if self.is_kw("ends") && self.is_kw_at(1, "with") {
                self.grow()?;
                self.advance();
                self.advance();
                let r = self.add_expr()?;
                l = Expr::Bin(BinOp::EndsWith, Box::new(l), Box::new(r));
            } else if self.is_kw("contains") {
                self.grow()?;
                self.advance();
                let r = self.add_expr()?;
                l = Expr::Bin(BinOp::Contains, Box::new(l), Box::new(r));
            } else if self.is_sym("=~") {
                self.grow()?;
                self.advance();
                let r = self.add_expr()?;
                l = Expr::Bin(BinOp::Regex, Box::new(l), Box::new(r));
            } else {
                break;
            }
        }
        Ok(l)
    }
    /// A left-associative chain of `next` operands joined by any of `ops` (symbols, or
    /// keywords matched without case).
    fn left_chain(&mut self, ops: &[(&str, BinOp)], next: fn(&mut Self) -> R<Expr>) -> R<Expr> {
        let mut l = next(self)?;
        while let Some((_, op)) = ops.iter().find(|(t, _)| self.is_sym(t) || self.is_kw(t)) {
            self.advance();
            self.grow()?;
            let r = next(self)?;
            l = Expr::Bin(*op, Box::new(l), Box::new(r));
        }
        Ok(l)
    }
    fn add_expr(&mut self) -> R<Expr> {
        self.left_chain(&[("+", BinOp::Add), ("-", BinOp::Sub)], Self::mul_expr)
    }
    fn mul_expr(&mut self) -> R<Expr> {
        self.left_chain(
            &[("*", BinOp::Mul), ("/", BinOp::Div), ("%", BinOp::Mod)],
            Self::pow_expr,
        )
    }
    fn pow_expr(&mut self) -> R<Expr> {
        let mut l = self.unary_expr()?;
        while self.eat_sym("^") {
            self.grow()?;
            let r = self.unary_expr()?;
            l = Expr::Bin(BinOp::Pow, Box::new(l), Box::new(r));
        }
        Ok(l)
    }
    fn unary_expr(&mut self) -> R<Expr> {
        if self.is_sym("-") {
            let pos = self.pos();
            self.advance();
            // -9223372036854775808 is a valid literal
            if let Tok::Int(i) = *self.tok()
                && !matches!(self.tok_at(1), Tok::Sym("." | "[" | "^"))
            {
                self.advance();
                return if i <= i64::MAX as u64 + 1 {
                    Ok(Expr::Lit(Val::Int((i as i128).wrapping_neg() as i64)))
                } else {
                    Err(QueryError::syntax(
                        "IntegerOverflow",
                        format!("integer literal -{i} is too large"),
                        Some(pos),
                    ))
                };
            }
            self.depth += 1;
            if self.depth > MAX_DEPTH {
                return Err(QueryError::syntax(
                    "UnexpectedSyntax",
                    "expression nested too deeply",
                    Some(pos),
                ));
            }
            let e = self.unary_expr();
            self.depth -= 1;
            return Ok(Expr::Neg(Box::new(e?)));
        }
        if self.eat_sym("+") {
            return self.unary_expr();
        }
        self.postfix_expr()
    }
    fn postfix_expr(&mut self) -> R<Expr> {
        let mut e = self.atom()?;
        loop {
            if self.is_sym(".") {
                self.grow()?;
                self.advance();
                let key = self.name()?;
                e = Expr::Prop(Box::new(e), key);
            } else if self.is_sym("[") {
                self.grow()?;
                self.advance();
                if self.eat_sym("..") {
                    let hi = if self.is_sym("]") {
                        None
                    } else {
                        Some(Box::new(self.expr()?))
                    };
                    self.expect_sym("]")?;
                    e = Expr::Slice(Box::new(e), None, hi);
                    continue;
                }
                let idx = self.expr()?;
                if self.eat_sym("..") {
                    let hi = if self.is_sym("]") {
                        None
                    } else {
                        Some(Box::new(self.expr()?))
                    };
                    self.expect_sym("]")?;
                    e = Expr::Slice(Box::new(e), Some(Box::new(idx)), hi);
                } else {
                    self.expect_sym("]")?;
                    e = Expr::Index(Box::new(e), Box::new(idx));
                }
            } else if self.is_sym(":") && matches!(self.tok_at(1), Tok::Ident(_) | Tok::Quoted(_)) {
                let mut labels = Vec::new();
                while self.eat_sym(":") {
                    labels.push(self.name()?);
                }
                e = Expr::HasLabels(Box::new(e), labels);
            } else {
                break;
            }
        }
        Ok(e)
    }

    fn atom(&mut self) -> R<Expr> {
        let pos = self.pos();
        match self.tok().clone() {
            Tok::Int(i) => {
                self.advance();
                if i > i64::MAX as u64 {
                    return Err(QueryError::syntax(
                        "IntegerOverflow",
                        format!("integer literal {i} is too large"),
                        Some(pos),
                    ));
                }
                Ok(Expr::Lit(Val::Int(i as i64)))
            }
            Tok::Float(f) => {
                self.advance();
                Ok(Expr::Lit(Val::Float(f)))
            }
            Tok::Str(s) => {
                self.advance();
                Ok(Expr::Lit(Val::Str(s)))
            }
            Tok::Param(p) => {
                self.advance();
                Ok(Expr::Param(p, pos))
            }
            Tok::Sym("{") => self.map_literal(),
            Tok::Sym("[") => self.list_atom(),
            Tok::Sym("(") => {
                if let Some(p) = self.try_pattern()? {
                    return Ok(Expr::Pattern(Box::new(p)));
                }
                self.advance();
                let e = self.expr()?;
                self.expect_sym(")")?;
                Ok(e)
            }
            Tok::Ident(s) => {
                let lower = s.to_ascii_lowercase();
                match lower.as_str() {
                    "null" => {
                        self.advance();
                        return Ok(Expr::Lit(Val::Null));
                    }
                    "true" => {
                        self.advance();
                        return Ok(Expr::Lit(Val::Bool(true)));
                    }
                    "false" => {
                        self.advance();
                        return Ok(Expr::Lit(Val::Bool(false)));
                    }
                    "case" => return self.case_expr(),
                    "exists" | "count" if matches!(self.tok_at(1), Tok::Sym("{")) => {
                        return self.subquery_expr(lower == "count");
                    }
                    "count"
                        if matches!(self.tok_at(1), Tok::Sym("("))
                            && matches!(self.tok_at(2), Tok::Sym("*")) =>
                    {
                        self.advance();
                        self.advance();
                        self.advance();
                        self.expect_sym(")")?;
                        return Ok(Expr::CountStar);
                    }
                    "all" | "any" | "none" | "single"
                        if matches!(self.tok_at(1), Tok::Sym("("))
                            && matches!(self.tok_at(2), Tok::Ident(_) | Tok::Quoted(_))
                            && self.is_kw_at(3, "in") =>
                    {
                        self.advance();
                        self.advance();
                        let var = self.var_name()?;
                        self.expect_kw("in")?;
                        let list = self.expr()?;
                        let pred = if self.eat_kw("where") {
                            self.expr()?
                        } else {
                            return self.err("WHERE in a quantifier");
                        };
                        self.expect_sym(")")?;
                        let q = match lower.as_str() {
                            "all" => Quant::All,
                            "any" => Quant::Any,
                            "none" => Quant::None,
                            _ => Quant::Single,
                        };
                        return Ok(Expr::Quantified {
                            q,
                            var,
                            list: Box::new(list),
                            pred: Box::new(pred),
                        });
                    }
                    "reduce" if matches!(self.tok_at(1), Tok::Sym("(")) => {
                        self.advance();
                        self.advance();
                        let acc = self.var_name()?;
                        self.expect_sym("=")?;
                        let init = self.expr()?;
                        self.expect_sym(",")?;
                        let var = self.var_name()?;
                        self.expect_kw("in")?;
                        let list = self.expr()?;
                        self.expect_sym("|")?;
                        let expr = self.expr()?;
                        self.expect_sym(")")?;
                        return Ok(Expr::Reduce {
                            acc,
                            init: Box::new(init),
                            var,
                            list: Box::new(list),
                            expr: Box::new(expr),
                        });
                    }
                    _ => {}
                }
                // function call: name(.name)* '('
                let mut k = 1;
                while matches!(self.tok_at(k), Tok::Sym("."))
                    && matches!(self.tok_at(k + 1), Tok::Ident(_) | Tok::Quoted(_))
                {
                    k += 2;
                }
                if matches!(self.tok_at(k), Tok::Sym("(")) {
                    let mut name = self.name()?;
                    while self.eat_sym(".") {
                        name.push('.');
                        name.push_str(&self.name()?);
                    }
                    self.expect_sym("(")?;
                    let distinct = self.eat_kw("distinct");
                    let mut args = Vec::new();
                    if !self.is_sym(")") {
                        args = self.expr_list()?;
                    }
                    self.expect_sym(")")?;
                    return Ok(Expr::Func {
                        name,
                        distinct,
                        args,
                        pos,
                    });
                }
                let v = self.var_name()?;
                if self.is_sym("{") {
                    return self.map_projection(Expr::Var(v, pos));
                }
                Ok(Expr::Var(v, pos))
            }
            Tok::Quoted(v) => {
                self.advance();
                if self.is_sym("{") {
                    return self.map_projection(Expr::Var(v, pos));
                }
                Ok(Expr::Var(v, pos))
            }
            _ => self.err("an expression"),
        }
    }

    fn map_projection(&mut self, base: Expr) -> R<Expr> {
        self.expect_sym("{")?;
        let mut items = Vec::new();
        if !self.is_sym("}") {
            loop {
                if self.eat_sym(".") {
                    if self.eat_sym("*") {
                        items.push(MapProjItem::AllProps);
                    } else {
                        items.push(MapProjItem::Prop(self.name()?));
                    }
                } else if matches!(self.tok_at(1), Tok::Sym(":")) {
                    let k = self.name()?;
                    self.expect_sym(":")?;
                    items.push(MapProjItem::Lit(k, self.expr()?));
                } else {
                    items.push(MapProjItem::Var(self.var_name()?));
                }
                if !self.eat_sym(",") {
                    break;
                }
            }
        }
        self.expect_sym("}")?;
        Ok(Expr::MapProj(Box::new(base), items))
    }

    /// Tries to read a relationship pattern at `(`; restores the position when it is not one.
    fn try_pattern(&mut self) -> R<Option<PathPattern>> {
        let save = self.i;
        let depth = self.depth;
        let chain = self.chain;
        match self.path_pattern() {
            Ok(p) if !p.steps.is_empty() => Ok(Some(p)),
            _ => {
                self.i = save;
                self.depth = depth;
                self.chain = chain;
                Ok(None)
            }
        }
    }

    fn list_atom(&mut self) -> R<Expr> {
        self.expect_sym("[")?;
        // list comprehension
        if matches!(self.tok(), Tok::Ident(_) | Tok::Quoted(_))
            && self.is_kw_at(1, "in")
            && self.at_var()
        {
            let var = self.var_name()?;
            self.expect_kw("in")?;
            let list = self.expr()?;
            let filter = if self.eat_kw("where") {
                Some(Box::new(self.expr()?))
            } else {
                None
            };
            let map = if self.eat_sym("|") {
                Some(Box::new(self.expr()?))
            } else {
                None
            };
            self.expect_sym("]")?;
            return Ok(Expr::ListComp {
                var,
                list: Box::new(list),
                filter,
                map,
            });
        }
        // pattern comprehension
        if self.is_sym("(") || (self.at_var() && matches!(self.tok_at(1), Tok::Sym("="))) {
            let save = self.i;
            if let Ok(p) = self.path_pattern()
                && !p.steps.is_empty()
                && (self.is_kw("where") || self.is_sym("|"))
            {
                let filter = if self.eat_kw("where") {
                    Some(Box::new(self.expr()?))
                } else {
                    None
                };
                self.expect_sym("|")?;
                let map = self.expr()?;
                self.expect_sym("]")?;
                return Ok(Expr::PatternComp {
                    pattern: Box::new(p),
                    filter,
                    map: Box::new(map),
                });
            }
            self.i = save;
        }
        let mut items = Vec::new();
        if !self.is_sym("]") {
            items = self.expr_list()?;
        }
        self.expect_sym("]")?;
        Ok(Expr::List(items))
    }

    fn case_expr(&mut self) -> R<Expr> {
        self.expect_kw("case")?;
        let subject = if self.is_kw("when") {
            None
        } else {
            Some(Box::new(self.expr()?))
        };
        let mut whens = Vec::new();
        while self.eat_kw("when") {
            let w = self.expr()?;
            self.expect_kw("then")?;
            let t = self.expr()?;
            whens.push((w, t));
        }
        if whens.is_empty() {
            return self.err("WHEN");
        }
        let else_ = if self.eat_kw("else") {
            Some(Box::new(self.expr()?))
        } else {
            None
        };
        self.expect_kw("end")?;
        Ok(Expr::Case {
            subject,
            whens,
            else_,
        })
    }
}

/// The variable whose labels SET or REMOVE change.
fn label_target(e: Expr, pos: Pos, clause: &str) -> R<String> {
    match e {
        Expr::Var(var, _) => Ok(var),
        _ => Err(QueryError::syntax(
            "UnexpectedSyntax",
            format!("{clause} of labels needs a variable"),
            Some(pos),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_typical_query() {
        let s = parse("MATCH (a:Lane {id: 1})-[:NEXT*1..3]->(b) WHERE b.x > 2 RETURN a, count(*) AS n ORDER BY n DESC LIMIT 5").unwrap();
        assert_eq!(s.parts.len(), 1);
        assert_eq!(s.parts[0].clauses.len(), 2);
    }

    #[test]
    fn errors_carry_line_and_column() {
        let e = parse("MATCH (n)\nRETURN n +").unwrap_err();
        assert_eq!(e.pos, Some(Pos { line: 2, col: 11 }));
        let e = parse("MATCH (n RETURN n").unwrap_err();
        assert_eq!(e.pos.map(|p| p.line), Some(1));
    }

    #[test]
    fn backtick_names_and_parameters_read_alike() {
        let s = parse("MATCH (`a``b`) RETURN $`p``q` AS `x y`").unwrap();
        let Clause::Return(p) = &s.parts[0].clauses[1] else {
            panic!()
        };
        assert!(matches!(&p.items[0].expr, Expr::Param(n, _) if n == "p`q"));
        assert_eq!(p.items[0].name, "x y");
        assert!(parse("RETURN $`open").is_err() && parse("MATCH (`open) RETURN 1").is_err());
    }

    #[test]
    fn unary_minus_binds_tighter_than_power() {
        let s = parse("RETURN -2 ^ 2").unwrap();
        let Clause::Return(p) = &s.parts[0].clauses[0] else {
            panic!()
        };
        assert!(matches!(p.items[0].expr, Expr::Bin(BinOp::Pow, _, _)));
        assert_eq!(p.items[0].name, "-2 ^ 2");
    }
}
