//! Installing a schema in a write transaction (`Store::set_schema`): the declared rules and
//! the indexes they need, checked against the nodes already stored.

use super::*;

impl WriteTxn<'_> {
    pub(crate) fn install_schema(
        &mut self,
        schema: &crate::schema::Schema,
    ) -> Result<Arc<Compiled>> {
        // intern every name the schema uses
        let mut labels = Vec::new();
        let mut types = Vec::new();
        let mut keys = Vec::new();
        for (l, r) in &schema.labels {
            labels.push(l.clone());
            keys.extend(r.properties.iter().map(|p| p.key.clone()));
            keys.extend(r.unique.iter().cloned());
        }
        for (t, r) in &schema.relationships {
            types.push(t.clone());
            keys.extend(r.properties.iter().map(|p| p.key.clone()));
            labels.extend(r.from_labels.iter().chain(&r.to_labels).cloned());
        }
        for p in &schema.property_indexes {
            labels.push(p.label.clone());
            keys.push(p.key.clone());
        }
        for s in &schema.spatial_indexes {
            labels.push(s.label.clone());
            keys.push(s.position_key.clone());
            keys.extend(s.box_key.clone());
        }
        for v in &schema.vector_indexes {
            labels.push(v.label.clone());
            keys.push(v.key.clone());
        }
        for t in &schema.text_indexes {
            labels.push(t.label.clone());
            keys.push(t.key.clone());
        }
        for l in labels {
            self.label_id(&l)?;
        }
        for t in types {
            self.rel_type_id(&t)?;
        }
        for k in keys {
            self.prop_key_id(&k)?;
        }
        let compiled = {
            let tok = |kind: TokenKind, n: &str| {
                Raw::token(self, kind, n)
                    .ok_or_else(|| Error::Schema(format!("{} {n:?} was not interned", kind.noun())))
            };
            Compiled::compile(
                schema,
                |n| tok(TokenKind::Label, n),
                |n| tok(TokenKind::RelType, n),
                |n| tok(TokenKind::PropKey, n),
            )?
        };
        let compiled = Arc::new(compiled);
        self.schema = compiled.clone();
        self.pending = PendingMem::for_schema(&compiled);
        // every rule, index and check below is about nodes of some label: the nodes of the
        // labels the schema names are the only ones to visit (a store's other nodes can be
        // most of it)
        let mut named: Vec<u32> = compiled.labels.keys().copied().collect();
        named.extend(compiled.prop_indexes.iter().map(|p| p.label));
        named.extend(compiled.spatial.iter().map(|s| s.label));
        named.extend(compiled.vector.iter().map(|v| v.label));
        named.extend(compiled.text.iter().map(|t| t.label));
        named.sort_unstable();
        named.dedup();
        let mut visit: Vec<u64> = Vec::new();
        for l in named {
            visit.extend(Raw::label_nodes(self, l)?);
        }
        visit.sort_unstable();
        visit.dedup();
        // a vector index over a property written as lists of numbers (before the index was
        // declared): store them as vectors, as writing them now would
        if !compiled.vector.is_empty() {
            for &id in &visit {
                let rec = self.rec(id)?;
                for v in &compiled.vector {
                    if !rec.has_label(v.label) {
                        continue;
                    }
                    if let Some(Value::List(items)) = rec.get(v.key)
                        && !items.is_empty()
                        && let Some(xs) = items
                            .iter()
                            .map(|x| match x {
                                Value::Int(n) => Some(*n as f32),
                                Value::Float(f) => Some(*f as f32),
                                _ => None,
                            })
                            .collect::<Option<Vec<f32>>>()
                    {
                        self.set_node_prop(id, PropKey(v.key), Value::Vector(xs))?;
                    }
                }
            }
        }
        // rebuild the property index from scratch, checking every node on the way
        let old: Vec<Vec<u8>> = Raw::raw_propidx_rows(self)?;
        for k in old {
            self.propidx.remove(k.as_slice()).map_err(storage)?;
        }
        for &id in &visit {
            let rec = self.rec(id)?;
            for (i, pi) in compiled.prop_indexes.iter().enumerate() {
                if rec.has_label(pi.label)
                    && let Some(k) = rec.get(pi.key).and_then(|v| pidx_key(i as u32, v, id))
                {
                    self.propidx.insert(k.as_slice(), &()).map_err(storage)?;
                }
            }
        }
        for &id in &visit {
            let rec = self.rec(id)?;
            self.check_node(id, &rec).map_err(|e| match e {
                Error::Constraint { target, detail } => Error::Schema(format!(
                    "existing node {id} breaks the new schema: {target}: {detail}"
                )),
                other => other,
            })?;
        }
        // only relationships of a type with a rule can break it
        let ruled = !compiled.rels.is_empty();
        for id in ruled
            .then(|| Raw::all_rels(self))
            .transpose()?
            .unwrap_or_default()
        {
            let rel = Raw::load_rel(self, id)?.ok_or(Error::RelNotFound(id))?;
            if !compiled.rels.contains_key(&rel.ty.0) {
                continue;
            }
            let (s, e) = (self.rec(rel.start)?, self.rec(rel.end)?);
            self.check_rel(rel.ty.0, &s.labels, &e.labels, &raw_props(&rel.props))
                .map_err(|err| match err {
                    Error::Constraint { target, detail } => Error::Schema(format!(
                        "existing relationship {id} breaks the new schema: {target}: {detail}"
                    )),
                    other => other,
                })?;
        }
        let bytes = serde_json::to_vec(schema).map_err(storage)?;
        self.meta
            .insert("schema", bytes.as_slice())
            .map_err(storage)?;
        Ok(compiled)
    }
}

#[cfg(test)]
mod tests {
    use crate::schema::{LabelRule, PropertyIndexSpec, PropertyRule, RelRule, Schema};
    use crate::{GraphRead, Store, Value, ValueType};

    /// A schema installed over a store checks the nodes of the labels it names and the
    /// relationships of the types it rules, and indexes the nodes of its indexed labels; the
    /// other nodes and relationships are left unvisited.
    #[test]
    fn installing_checks_and_indexes_only_what_the_schema_names() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::create(dir.path().join("s.og")).unwrap();
        let (a, b, c) = store
            .write(|tx| {
                let a = tx.create_node_named(&["A"], &[("n", Value::from("x"))])?;
                let b = tx.create_node_named(&["B"], &[("n", Value::Int(1))])?;
                let c = tx.create_node_named(&["C"], &[("n", Value::from("free"))])?;
                for _ in 0..50 {
                    tx.create_rel_named(c, "S", c, &[])?;
                }
                tx.create_rel_named(c, "R", b, &[])?;
                Ok((a, b, c))
            })
            .unwrap();
        let int_n = || LabelRule {
            properties: vec![PropertyRule {
                key: "n".into(),
                ty: ValueType::Int,
                required: true,
            }],
            ..LabelRule::default()
        };
        // A's string breaks an integer rule on A
        let mut bad = Schema::default();
        bad.labels.insert("A".into(), int_n());
        let e = store.set_schema(bad).unwrap_err().to_string();
        assert!(e.contains(&format!("existing node {a}")), "{e}");
        // R from C breaks a rule that R starts at B; the many S relationships have no rule
        let mut bad = Schema::default();
        bad.relationships.insert(
            "R".into(),
            RelRule {
                from_labels: vec!["B".into()],
                ..RelRule::default()
            },
        );
        let e = store.set_schema(bad).unwrap_err().to_string();
        assert!(e.contains("existing relationship 50"), "{e}");
        // an integer rule on B, an index on B.n and C's string unchecked: installed, indexed
        let mut good = Schema::default();
        good.labels.insert("B".into(), int_n());
        good.property_indexes.push(PropertyIndexSpec {
            name: None,
            label: "B".into(),
            key: "n".into(),
        });
        store.set_schema(good).unwrap();
        let got = store
            .read()
            .unwrap()
            .find_nodes("B", "n", &Value::Int(1))
            .unwrap();
        assert_eq!(got, vec![b]);
        assert_ne!(b, c);
    }
}
