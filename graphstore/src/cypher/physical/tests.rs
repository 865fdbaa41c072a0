//! The operators over an in-memory graph, without a store.

use std::collections::BTreeMap;
use std::rc::Rc;
use std::sync::Arc;

use super::super::R;
use super::super::ast::Expr;
use super::super::source::{Source, Types, Way};
use super::super::value::Val;
use super::*;
use crate::columns::LabelMembers;
use crate::{Value, ValueBound};

/// A small graph in memory: nodes with labels and properties, relationships with a type.
#[derive(Debug, Default)]
pub(crate) struct MemSource {
    pub labels: Vec<String>,
    pub types: Vec<String>,
    pub keys: Vec<String>,
    /// Per node id: label ids and properties by key id.
    pub nodes: BTreeMap<u64, (Vec<u32>, BTreeMap<u32, Val>)>,
    /// Per relationship id: (type, start, end, properties).
    pub rels: BTreeMap<u64, (u32, u64, u64, BTreeMap<u32, Val>)>,
}

fn intern(v: &mut Vec<String>, name: &str) -> u32 {
    match v.iter().position(|x| x == name) {
        Some(i) => i as u32,
        None => {
            v.push(name.to_string());
            (v.len() - 1) as u32
        }
    }
}

impl MemSource {
    pub(crate) fn node(&mut self, id: u64, labels: &[&str], props: &[(&str, Val)]) {
        let l = labels.iter().map(|x| intern(&mut self.labels, x)).collect();
        let p = props
            .iter()
            .map(|(k, v)| (intern(&mut self.keys, k), v.clone()))
            .collect();
        self.nodes.insert(id, (l, p));
    }

    pub(crate) fn rel(&mut self, id: u64, ty: &str, a: u64, b: u64, props: &[(&str, Val)]) {
        let t = intern(&mut self.types, ty);
        let p = props
            .iter()
            .map(|(k, v)| (intern(&mut self.keys, k), v.clone()))
            .collect();
        self.rels.insert(id, (t, a, b, p));
    }
}

impl Source for MemSource {
    fn label_id(&self, name: &str) -> Option<u32> {
        self.labels.iter().position(|x| x == name).map(|i| i as u32)
    }
    fn type_id(&self, name: &str) -> Option<u32> {
        self.types.iter().position(|x| x == name).map(|i| i as u32)
    }
    fn key_id(&self, name: &str) -> Option<u32> {
        self.keys.iter().position(|x| x == name).map(|i| i as u32)
    }
    fn label_nodes(&self, label: u32) -> R<Arc<LabelMembers>> {
        Ok(Arc::new(LabelMembers::new(
            self.nodes
                .iter()
                .filter(|(_, (l, _))| l.contains(&label))
                .map(|(id, _)| *id)
                .collect(),
        )))
    }
    fn all_nodes(&self) -> R<Vec<u64>> {
        Ok(self.nodes.keys().copied().collect())
    }
    fn has_label(&self, node: u64, label: u32) -> R<bool> {
        Ok(self
            .nodes
            .get(&node)
            .is_some_and(|(l, _)| l.contains(&label)))
    }
    fn expand(&self, node: u64, way: Way, types: &Types, out: &mut Vec<(u64, u64)>) -> R<()> {
        let ok = |t: u32| match types {
            Types::Any => true,
            Types::Only(ts) => ts.contains(&t),
        };
        // the store's order: direction (out first), type, relationship id
        let mut rows: Vec<(u8, u32, u64, u64)> = Vec::new();
        for (rid, (t, a, b, _)) in &self.rels {
            if !ok(*t) {
                continue;
            }
            if *a == node && way != Way::In {
                rows.push((0, *t, *rid, *b));
            }
            if *b == node && way != Way::Out && !(way == Way::Both && *a == node) {
                rows.push((1, *t, *rid, *a));
            }
        }
        rows.sort_unstable();
        out.extend(rows.into_iter().map(|(_, _, r, o)| (r, o)));
        Ok(())
    }
    fn node_prop_handle(&self, key: Option<u32>) -> usize {
        key.map_or(usize::MAX, |k| k as usize)
    }
    fn rel_prop_handle(&self, key: Option<u32>) -> usize {
        key.map_or(usize::MAX, |k| k as usize)
    }
    fn node_prop(&self, node: u64, handle: usize) -> R<Val> {
        Ok(self
            .nodes
            .get(&node)
            .and_then(|(_, p)| p.get(&(handle as u32)).cloned())
            .unwrap_or(Val::Null))
    }
    fn rel_prop(&self, rel: u64, handle: usize) -> R<Val> {
        Ok(self
            .rels
            .get(&rel)
            .and_then(|(_, _, _, p)| p.get(&(handle as u32)).cloned())
            .unwrap_or(Val::Null))
    }
    fn node_column(&self, _h: usize, _force: bool) -> Option<Arc<crate::columns::Column>> {
        None
    }
    fn rel_column(&self, _h: usize, _force: bool) -> Option<Arc<crate::columns::Column>> {
        None
    }
    fn adjacency(&self, _force: bool) -> Option<Arc<crate::hot::AdjMem>> {
        None
    }
    fn has_index(&self, _label: &str, _key: &str) -> bool {
        false
    }
    fn index_eq(&self, _label: &str, _key: &str, _v: &Value) -> R<Vec<u64>> {
        Ok(Vec::new())
    }
    fn index_range(
        &self,
        _label: &str,
        _key: &str,
        _lo: ValueBound,
        _hi: ValueBound,
    ) -> R<Vec<u64>> {
        Ok(Vec::new())
    }
    fn node_count(&self) -> u64 {
        self.nodes.len() as u64
    }
    fn label_count(&self, label: &str) -> u64 {
        self.label_id(label).map_or(0, |l| {
            self.nodes
                .values()
                .filter(|(ls, _)| ls.contains(&l))
                .count() as u64
        })
    }
}

/// A host without a statement: parameters, no limits, no interpreter behind it.
#[derive(Debug, Default)]
pub(crate) struct BareHost {
    pub params: BTreeMap<String, Val>,
}

impl Host for BareHost {
    fn tick(&self) -> R<()> {
        Ok(())
    }
    fn room(&self, _rows: usize) -> R<()> {
        Ok(())
    }
    fn reserve(&self, _bytes: u64, _what: &str) -> R<()> {
        Ok(())
    }
    fn param(&self, name: &str) -> Option<&Val> {
        self.params.get(name)
    }
    fn call(&self, lower: &str, _name: &str, args: Vec<Val>) -> R<Val> {
        match (lower, args.as_slice()) {
            ("tolower", [Val::Str(s)]) => Ok(Val::Str(s.to_lowercase())),
            _ => Err(super::super::eval::arg_err(
                "UnknownFunction",
                format!("{lower}() is not in the test host"),
            )),
        }
    }
    fn eval_fallback(&self, _e: &Expr, _vars: &[(Rc<str>, Val)]) -> R<Val> {
        Err(super::super::eval::arg_err(
            "Unsupported",
            "the test host has no interpreter",
        ))
    }
    fn count_arg(&self, e: &Expr, _what: &str) -> R<Option<usize>> {
        match e {
            Expr::Lit(Val::Int(i)) if *i >= 0 => Ok(Some(*i as usize)),
            _ => Err(super::super::eval::arg_err("Bad", "not a count")),
        }
    }
}

/// Rows of a query over a source, planned and run without a store.
pub(crate) fn run(text: &str, src: &MemSource, host: &BareHost) -> Option<Vec<Vec<Val>>> {
    let stmt = super::super::parser::parse(text).expect("parses");
    super::super::check::check(&stmt).expect("checks");
    let lp = super::super::logical::build(&stmt.parts[0])?;
    let mut plan = planner::plan(&lp, src)?;
    let ex = Exec { src, host };
    Some(plan.run(&ex).expect("runs"))
}

fn city() -> MemSource {
    let mut g = MemSource::default();
    let s = |x: &str| Val::Str(x.to_string());
    g.node(1, &["Segment"], &[("kind", s("crossroad"))]);
    g.node(2, &["Segment"], &[("kind", s("t_junction"))]);
    g.node(
        10,
        &["Instance"],
        &[("label", s("bench")), ("score", Val::Float(0.5))],
    );
    g.node(
        11,
        &["Instance"],
        &[("label", s("bin")), ("score", Val::Float(0.9))],
    );
    g.node(
        12,
        &["Instance"],
        &[("label", s("bench")), ("score", Val::Int(1))],
    );
    g.rel(100, "IN_SEGMENT", 10, 1, &[]);
    g.rel(101, "IN_SEGMENT", 11, 1, &[]);
    g.rel(102, "IN_SEGMENT", 12, 2, &[]);
    g.rel(103, "NEAR", 10, 11, &[("distance_m", Val::Float(2.0))]);
    g.rel(104, "NEAR", 11, 12, &[("distance_m", Val::Float(5.0))]);
    g
}

#[test]
fn scans_expand_filter_and_group_without_a_store() {
    let g = city();
    let h = BareHost::default();
    let rows = run(
        "MATCH (i:Instance)-[:IN_SEGMENT]->(s:Segment) RETURN s.kind AS k, count(*) AS n, avg(i.score) AS a ORDER BY k",
        &g,
        &h,
    )
    .expect("pipelined");
    assert_eq!(
        rows,
        vec![
            vec![Val::Str("crossroad".into()), Val::Int(2), Val::Float(0.7)],
            vec![Val::Str("t_junction".into()), Val::Int(1), Val::Float(1.0)],
        ]
    );
    // relationship uniqueness inside a MATCH, both directions
    let rows = run(
        "MATCH (a:Instance)-[:NEAR]-(b)-[:NEAR]-(c) WHERE a.label = 'bench' RETURN c.label AS l",
        &g,
        &h,
    )
    .unwrap();
    // 10-11-12 and 12-11-10, each once: the NEAR taken first is not taken again
    assert_eq!(
        rows,
        vec![
            vec![Val::Str("bench".into())],
            vec![Val::Str("bench".into())]
        ]
    );
}

#[test]
fn optional_match_limit_distinct_and_unwind() {
    let g = city();
    let h = BareHost::default();
    let rows = run(
        "MATCH (s:Segment) OPTIONAL MATCH (s)<-[:IN_SEGMENT]-(i:Instance {label: 'bin'}) RETURN s.kind AS k, i.label AS l",
        &g,
        &h,
    )
    .unwrap();
    assert_eq!(
        rows,
        vec![
            vec![Val::Str("crossroad".into()), Val::Str("bin".into())],
            vec![Val::Str("t_junction".into()), Val::Null],
        ]
    );
    let rows = run(
        "MATCH (i:Instance) RETURN DISTINCT i.label AS l ORDER BY l DESC LIMIT 1",
        &g,
        &h,
    )
    .unwrap();
    assert_eq!(rows, vec![vec![Val::Str("bin".into())]]);
    let rows = run(
        "UNWIND [3, 1, 2, null] AS x WITH x WHERE x > 1 RETURN sum(x) AS s, collect(x) AS c",
        &g,
        &h,
    )
    .unwrap();
    assert_eq!(
        rows,
        vec![vec![Val::Int(5), Val::List(vec![Val::Int(3), Val::Int(2)])]]
    );
}
