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
        // a vector index over a property written as lists of numbers (before the index was
        // declared): store them as vectors, as writing them now would
        if !compiled.vector.is_empty() {
            for id in Raw::all_nodes(self)? {
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
        for id in Raw::all_nodes(self)? {
            let rec = self.rec(id)?;
            for (i, pi) in compiled.prop_indexes.iter().enumerate() {
                if rec.has_label(pi.label)
                    && let Some(k) = rec.get(pi.key).and_then(|v| pidx_key(i as u32, v, id))
                {
                    self.propidx.insert(k.as_slice(), &()).map_err(storage)?;
                }
            }
        }
        for id in Raw::all_nodes(self)? {
            let rec = self.rec(id)?;
            self.check_node(id, &rec).map_err(|e| match e {
                Error::Constraint { target, detail } => Error::Schema(format!(
                    "existing node {id} breaks the new schema: {target}: {detail}"
                )),
                other => other,
            })?;
        }
        for id in Raw::all_rels(self)? {
            let rel = Raw::load_rel(self, id)?.ok_or(Error::RelNotFound(id))?;
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
