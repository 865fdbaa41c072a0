//! A write checked against the declared schema before it touches anything: typed and
//! required properties, unique values, relationship ends.

use super::*;

impl WriteTxn<'_> {
    pub(super) fn check_props(
        &self,
        target: &str,
        rules: &[crate::compiled::CRule],
        props: &[(u32, Value)],
    ) -> Result<()> {
        for r in rules {
            match props.binary_search_by_key(&r.key, |(k, _)| *k) {
                Ok(i) => {
                    let v = &props[i].1;
                    if !r.ty.accepts(v) {
                        return Err(Error::Constraint {
                            target: target.into(),
                            detail: format!(
                                "property `{}` must be {}, got {}",
                                self.name(r.key),
                                r.ty,
                                v.value_type()
                            ),
                        });
                    }
                }
                Err(_) if r.required => {
                    return Err(Error::Constraint {
                        target: target.into(),
                        detail: format!(
                            "missing required property `{}` ({})",
                            self.name(r.key),
                            r.ty
                        ),
                    });
                }
                Err(_) => {}
            }
        }
        Ok(())
    }

    pub(super) fn check_node(&self, id: u64, rec: &NodeRec) -> Result<()> {
        let schema = self.schema.clone();
        for l in &rec.labels {
            let Some(rule) = schema.labels.get(l) else {
                continue;
            };
            let lname = self.name(*l);
            self.check_props(&lname, &rule.props, &rec.props)?;
            for (k, idx) in &rule.unique {
                let Some(v) = rec.get(*k) else { continue };
                let Some(sk) = sort_key(v) else {
                    return Err(Error::Constraint {
                        target: lname,
                        detail: format!(
                            "unique property `{}` must be a boolean, number or string",
                            self.name(*k)
                        ),
                    });
                };
                let mut lo = idx.to_be_bytes().to_vec();
                lo.extend_from_slice(&sk);
                let mut hi = lo.clone();
                hi.extend_from_slice(&[0xff; 8]);
                let others = Raw::propidx(self, Bound::Included(&lo), Bound::Included(&hi))?;
                for other in others.into_iter().filter(|o| *o != id) {
                    // index keys are f64-based: confirm the clash on the exact values
                    let same = Raw::load_rec(self, other)?
                        .and_then(|r| r.get(*k).cloned())
                        .is_some_and(|ov| {
                            crate::read::compare(&ov, v) == Some(std::cmp::Ordering::Equal)
                        });
                    if same {
                        return Err(Error::Constraint {
                            target: lname,
                            detail: format!(
                                "unique property `{}` = {} is already used by node {other}",
                                self.name(*k),
                                v.to_json()
                            ),
                        });
                    }
                }
            }
        }
        let bad = |target: String, detail: String| Err(Error::Constraint { target, detail });
        for s in &schema.spatial {
            if !rec.has_label(s.label) {
                continue;
            }
            if let Some(v) = rec.get(s.position)
                && (v.as_point3().is_none() || !v.is_finite())
            {
                return bad(
                    self.name(s.label),
                    format!(
                        "spatial position `{}` must be a finite point",
                        self.name(s.position)
                    ),
                );
            }
            if let Some(k) = s.bbox
                && let Some(v) = rec.get(k)
                && (v.as_box3d().is_none() || !v.is_finite())
            {
                return bad(
                    self.name(s.label),
                    format!(
                        "spatial box `{}` must be [min point, max point] with min <= max",
                        self.name(k)
                    ),
                );
            }
        }
        for v in &schema.vector {
            if !rec.has_label(v.label) {
                continue;
            }
            if let Some(val) = rec.get(v.key) {
                let ok = val.as_vector().is_some_and(|x| {
                    x.len() == v.params.dim && val.is_finite() && x.iter().any(|c| *c != 0.0)
                });
                if !ok {
                    return bad(
                        self.name(v.label),
                        format!(
                            "vector `{}` must be a finite, non-zero f32 vector of dimension {}",
                            self.name(v.key),
                            v.params.dim
                        ),
                    );
                }
            }
        }
        for t in &schema.text {
            if !rec.has_label(t.label) {
                continue;
            }
            if let Some(val) = rec.get(t.key) {
                let ok = matches!(val, Value::String(_))
                    || matches!(val, Value::List(items) if items.iter().all(|i| i.as_str().is_some()));
                if !ok {
                    return bad(
                        self.name(t.label),
                        format!(
                            "text `{}` must be a string or a list of strings",
                            self.name(t.key)
                        ),
                    );
                }
            }
        }
        Ok(())
    }

    /// Checks a relationship against its type's schema rule, given its ends' labels (sorted).
    pub(super) fn check_rel(
        &self,
        ty: u32,
        start: &[u32],
        end: &[u32],
        props: &[(u32, Value)],
    ) -> Result<()> {
        let Some(rule) = self.schema.rels.get(&ty) else {
            return Ok(());
        };
        let tname = self.name(ty);
        self.check_props(&tname, &rule.props, props)?;
        let names = |ls: &[u32]| {
            ls.iter()
                .map(|l| self.name(*l))
                .collect::<Vec<_>>()
                .join("|")
        };
        if !rule.from.is_empty() && !rule.from.iter().any(|l| start.binary_search(l).is_ok()) {
            return Err(Error::Constraint {
                target: tname,
                detail: format!("start node must be labelled {}", names(&rule.from)),
            });
        }
        if !rule.to.is_empty() && !rule.to.iter().any(|l| end.binary_search(l).is_ok()) {
            return Err(Error::Constraint {
                target: tname,
                detail: format!("end node must be labelled {}", names(&rule.to)),
            });
        }
        Ok(())
    }
}
