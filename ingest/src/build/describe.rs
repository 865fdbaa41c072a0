//! Describing an instance: caption embeddings, the class from the caption (closest class
//! prompt among surface or object classes), and the `Instance` node's properties.

use super::*;

/// Caption embeddings with a cache (captions repeat across frames).
pub(super) struct EmbedCache<'a> {
    pub(super) embedder: &'a mut dyn Embedder,
    pub(super) cache: HashMap<String, Vec<f32>>,
}

impl EmbedCache<'_> {
    pub(super) fn get_all(&mut self, texts: &[&str]) -> Result<Vec<Vec<f32>>> {
        let mut missing: Vec<&str> = texts
            .iter()
            .copied()
            .filter(|t| !self.cache.contains_key(*t))
            .collect();
        missing.sort_unstable();
        missing.dedup();
        if !missing.is_empty() {
            let v = self
                .embedder
                .embed(&missing)
                .map_err(|e| Error::Invalid(format!("embedding captions: {e}")))?;
            for (t, e) in missing.iter().zip(v) {
                self.cache.insert(t.to_string(), e);
            }
        }
        Ok(texts.iter().map(|t| self.cache[*t].clone()).collect())
    }
}

/// The class (1..=19) whose prompt is most similar to `v` (the embedding of a caption's
/// subject phrase).
/// The class whose prompt is closest to `v`, among surface classes when `surface`, else
/// among the others.
pub(super) fn argmax_class(v: &[f32], prompts: &[(u8, Vec<f32>)], surface: bool) -> u8 {
    let mut best = (f64::NEG_INFINITY, 0u8);
    for (class, p) in prompts
        .iter()
        .filter(|(c, _)| classes::is_surface(*c) == surface)
    {
        let c = crate::mapping::associate::cosine(v, p);
        if c > best.0 {
            best = (c, *class);
        }
    }
    best.1
}

/// Classes whose objects are joined when their points touch (building, fence, vegetation):
/// extended things a passing car sees in parts.
pub(super) const JOINED_CLASSES: [u8; 3] = [13, 14, 15];

/// The thing class of an object before its caption is merged: the most frequent class of
/// its recent captions (ties: the lower class id).
pub(super) fn object_class(
    o: &MapObject,
    cfg: &MappingConfig,
    emb: &mut EmbedCache<'_>,
    prompts: &[(u8, Vec<f32>)],
) -> Result<u8> {
    let subjects: Vec<&str> = o
        .recent_captions(cfg.merge_captions)
        .iter()
        .map(|c| llm_tools::vocab::subject_phrase(c))
        .collect();
    let mut votes: BTreeMap<u8, usize> = BTreeMap::new();
    for e in emb.get_all(&subjects)? {
        *votes.entry(argmax_class(&e, prompts, false)).or_insert(0) += 1;
    }
    Ok(votes
        .iter()
        .max_by_key(|(c, n)| (**n, std::cmp::Reverse(**c)))
        .map_or(0, |(c, _)| *c))
}

/// Class of each detection: whether it is a surface or a thing is decided by its tags or
/// caption ([`llm_tools::vocab::names_surface`]); its class is then the closest class prompt of that
/// kind to the caption's embedded subject phrase. Inputs are `(tags, caption)` pairs.
pub(super) fn classify(
    detections: &[(&[String], &str)],
    emb: &mut EmbedCache<'_>,
    prompts: &[(u8, Vec<f32>)],
) -> Result<Vec<u8>> {
    let subjects: Vec<&str> = detections
        .iter()
        .map(|(_, c)| llm_tools::vocab::subject_phrase(c))
        .collect();
    Ok(emb
        .get_all(&subjects)?
        .iter()
        .zip(detections)
        .map(|(e, (tags, caption))| {
            argmax_class(e, prompts, llm_tools::vocab::names_surface(tags, caption))
        })
        .collect())
}

pub(super) struct Description {
    pub(super) caption: String,
    pub(super) class: u8,
    pub(super) feature: Vec<f32>,
    /// The object's noun phrase (normalised across the map by the labelling pass).
    pub(super) label: Option<String>,
    pub(super) colour: Option<String>,
    pub(super) material: Option<String>,
}

/// The thing class of a label phrase: the class prompt with the best score, where a
/// compound's score is the mean of the phrase's and its head word's cosines (a "bus
/// shelter" is a shelter, not a bus), or 0 (`other-object`) when the best is below `below`.
pub(super) fn thing_class(
    phrase: &str,
    emb: &mut EmbedCache<'_>,
    prompts: &[(u8, Vec<f32>)],
    below: f64,
) -> Result<u8> {
    let head = llm_tools::labels::head_word(phrase);
    let compound = head != phrase;
    // with an article, as the prompts are written ("man" alone is far from "a man")
    let article = |w: &str| format!("a {w}");
    let (p, h) = (article(phrase), article(head));
    let v = emb.get_all(&[p.as_str(), h.as_str()])?;
    let mut best = (f64::NEG_INFINITY, 0u8);
    for (class, p) in prompts.iter().filter(|(c, _)| !classes::is_surface(*c)) {
        let cos = crate::mapping::associate::cosine(&v[0], p);
        let score = if compound {
            0.5 * (cos + crate::mapping::associate::cosine(&v[1], p))
        } else {
            cos
        };
        if score > best.0 {
            best = (score, *class);
        }
    }
    Ok(if best.0 < below { 0 } else { best.1 })
}

pub(super) fn describe(
    o: &MapObject,
    cfg: &MappingConfig,
    emb: &mut EmbedCache<'_>,
    merger: &mut dyn CaptionMerger,
    prompts: &[(u8, Vec<f32>)],
    lexicon: &llm_tools::labels::Lexicon,
) -> Result<Description> {
    let caption = merger.merge(o.recent_captions(cfg.merge_captions));
    let ce = emb.get_all(&[&caption])?.remove(0);
    let (class, label) = match o.tile {
        Some((c, _)) => (c, None),
        // an object is a thing whatever its merged caption says
        None => {
            let phrase = llm_tools::labels::object_phrase(&o.captions, lexicon)
                .unwrap_or_else(|| llm_tools::labels::noun_phrase(&caption, lexicon));
            let class = thing_class(&phrase, emb, prompts, cfg.other_object_below)?;
            (class, Some(phrase))
        }
    };
    let (colour, material) = if o.tile.is_none() {
        (
            llm_tools::labels::agreed_colour(&o.captions),
            llm_tools::labels::agreed_material(&o.captions),
        )
    } else {
        (None, None)
    };
    let feature = if o.feature.len() == ce.len() {
        let n = |v: &[f32]| v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
        let (na, nb) = (n(&ce), n(&o.feature));
        let mut f: Vec<f32> = ce
            .iter()
            .zip(&o.feature)
            .map(|(a, b)| 0.5 * a / na + 0.5 * b / nb)
            .collect();
        let nf = n(&f);
        f.iter_mut().for_each(|x| *x /= nf);
        f
    } else {
        ce
    };
    Ok(Description {
        caption,
        class,
        feature,
        label,
        colour,
        material,
    })
}

/// The `Instance` record of a mapped object described as `d`.
pub(super) fn instance_record(
    o: &MapObject,
    d: &Description,
    source: &str,
    ground: GroundFrame,
) -> InstanceRecord {
    InstanceRecord {
        instance_id: o.instance_id as i64,
        caption: d.caption.clone(),
        semantic_class: classes::class_name(d.class)
            .unwrap_or(classes::OTHER_OBJECT)
            .into(),
        label: d.label.clone(),
        colour: d.colour.clone(),
        material: d.material.clone(),
        centroid: o.bbox.center(),
        bbox: (o.bbox.min.map(f64::from), o.bbox.max.map(f64::from)),
        captions: Some(o.captions.to_vec()),
        feature: Some(d.feature.clone()),
        point_count: Some(o.points.len() as i64),
        detection_count: Some(i64::from(o.detection_count)),
        first_frame: Some(i64::from(o.first_frame)),
        last_frame: Some(i64::from(o.last_frame)),
        source: Some(source.into()),
        detection_feature: (!o.feature.is_empty()).then(|| o.feature.clone()),
        obb: o.obb(ground),
        tile: o.tile.map(|(class, [x, z])| [i64::from(class), x, z]),
    }
}
