"""Randomly initialised transformers models built from configs, with working processors: no download.
Test tooling, kept out of the package: tests and benchmarks import it as `fakes.hf_random` (a benchmark puts
tests/ on its path first, as `benchmarks/bench_models.py` does).

For tests (tiny sizes, saved to a folder and loaded by path through the real `hf:` backends) and for
speed benchmarks (the real architectures' sizes, written out below, built on the GPU in fp16/bf16).
Random weights give meaningless answers at the real cost. Tokenizers are made from a small vocabulary
(letters, and for byte-level BPE all 256 byte symbols); their ids stay below any model's vocabulary size.

Works with transformers 4.50 and later: only config classes, the model classes and the processors'
constructors are used; a missing class is reported with the version found.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from attribot.deps import require
from attribot.errors import ConfigError

__all__ = ["RANDOM_MODELS", "build_random", "save_random"]

_LETTERS = [chr(c) for c in range(ord("a"), ord("z") + 1)]
_DIGITS = [str(d) for d in range(10)]


def _tf() -> Any:
    require("torch", "random transformers models")
    return require("transformers", "random transformers models")


def _cls(name: str, *alternatives: str) -> Any:
    transformers = _tf()
    for n in (name, *alternatives):
        cls = getattr(transformers, n, None)
        if cls is not None:
            return cls
    raise ConfigError(
        f"this transformers ({transformers.__version__}) has no {name}",
        "pip install -U 'transformers>=4.50'",
    )


# ---- tokenizers built from a small vocabulary -----------------------------------------------------------


def _clip_tokenizer(folder: Path, max_length: int) -> Any:
    """CLIP BPE over letters and digits (no merges: a word is its letters). OWL needs BOS != 0 and
    EOS the highest id (the text model pools at the highest id when EOS is not set to 2)."""
    vocab: dict[str, int] = {"!": 0, "<|startoftext|>": 1}
    for tok in (
        _LETTERS
        + [c + "</w>" for c in _LETTERS]
        + _DIGITS
        + [d + "</w>" for d in _DIGITS]
        + [".", ".</w>", ",", ",</w>", "-", "-</w>"]
    ):
        vocab.setdefault(tok, len(vocab))
    vocab["<|endoftext|>"] = len(vocab)
    (folder / "vocab.json").write_text(json.dumps(vocab))
    (folder / "merges.txt").write_text("#version: 0.2\n")
    cls = _cls("CLIPTokenizerFast", "CLIPTokenizer")
    return cls.from_pretrained(str(folder), pad_token="!", model_max_length=max_length)


def _bert_tokenizer(folder: Path, max_length: int) -> Any:
    """WordPiece over letters, digits and a few whole words (Grounding DINO's text side is BERT)."""
    words = "a an the cat dog cup red blue mug bowl apple book remote control".split()
    toks = ["[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]", ".", ",", "-", *words, *_LETTERS, *_DIGITS]
    toks += ["##" + c for c in _LETTERS + _DIGITS]
    seen: list[str] = []
    for t in toks:
        if t not in seen:
            seen.append(t)
    (folder / "vocab.txt").write_text("\n".join(seen) + "\n")
    cls = _cls("BertTokenizerFast", "BertTokenizer")
    return cls.from_pretrained(str(folder), model_max_length=max_length)


def _bytes_to_unicode() -> dict[int, str]:
    """GPT-2's reversible map from bytes to printable characters (its byte-level BPE alphabet)."""
    bs = list(range(ord("!"), ord("~") + 1)) + list(range(0xA1, 0xAC + 1)) + list(range(0xAE, 0xFF + 1))
    cs = bs[:]
    n = 0
    for b in range(256):
        if b not in bs:
            bs.append(b)
            cs.append(256 + n)
            n += 1
    return dict(zip(bs, [chr(c) for c in cs], strict=True))


def _gpt2_tokenizer(folder: Path, max_length: int) -> Any:
    """Byte-level BPE (OPT's tokenizer family) over the 256 byte symbols, no merges."""
    vocab: dict[str, int] = {"<pad>": 0, "</s>": 1, "<unk>": 2}
    for ch in _bytes_to_unicode().values():
        vocab.setdefault(ch, len(vocab))
    (folder / "vocab.json").write_text(json.dumps(vocab))
    (folder / "merges.txt").write_text("#version: 0.2\n")
    cls = _cls("GPT2TokenizerFast", "GPT2Tokenizer")
    return cls.from_pretrained(
        str(folder),
        bos_token="</s>",
        eos_token="</s>",
        pad_token="<pad>",
        unk_token="<unk>",
        model_max_length=max_length,
    )


# ---- model specifications -------------------------------------------------------------------------------
# Real sizes are the configs of the published checkpoints (config.json on the hub), written out here so
# that nothing is downloaded: google/owlv2-base-patch16-ensemble, google/owlv2-large-patch14-ensemble,
# IDEA-Research/grounding-dino-tiny, Salesforce/blip2-opt-2.7b.


def _owl(
    text: dict[str, int], vision: dict[str, int], projection_dim: int, text_len: int
) -> Callable[[Path], tuple[Any, Any]]:
    def make(folder: Path) -> tuple[Any, Any]:
        tok = _clip_tokenizer(folder, text_len)
        config = _cls("Owlv2Config")(
            text_config=dict(
                text,
                max_position_embeddings=text_len,
                vocab_size=max(text.get("vocab_size", 0), len(tok)),
                bos_token_id=1,
                eos_token_id=len(tok) - 1,
                pad_token_id=0,
            ),
            vision_config=dict(vision),
            projection_dim=projection_dim,
        )
        side = vision["image_size"]
        image_processor = _cls("Owlv2ImageProcessor")(size={"height": side, "width": side})
        processor = _cls("Owlv2Processor")(image_processor=image_processor, tokenizer=tok)
        return config, processor

    return make


def _gdino(
    backbone: dict[str, Any], text: dict[str, int], main: dict[str, Any], image_size: dict[str, int]
) -> Callable[[Path], tuple[Any, Any]]:
    def make(folder: Path) -> tuple[Any, Any]:
        tok = _bert_tokenizer(folder, main["max_text_len"])
        config = _cls("GroundingDinoConfig")(
            backbone_config=dict(backbone, model_type="swin"),
            text_config=dict(text, model_type="bert", vocab_size=max(text.get("vocab_size", 0), len(tok))),
            **main,
        )
        image_processor = _cls("GroundingDinoImageProcessor")(size=dict(image_size))
        processor = _cls("GroundingDinoProcessor")(image_processor=image_processor, tokenizer=tok)
        return config, processor

    return make


def _blip2(
    vision: dict[str, int], qformer: dict[str, int], text: dict[str, int], n_query: int
) -> Callable[[Path], tuple[Any, Any]]:
    def make(folder: Path) -> tuple[Any, Any]:
        tok = _gpt2_tokenizer(folder, text["max_position_embeddings"])
        image_processor = _cls("BlipImageProcessor")(
            size={"height": vision["image_size"], "width": vision["image_size"]}
        )
        processor_cls = _cls("Blip2Processor")
        try:
            processor = processor_cls(
                image_processor=image_processor, tokenizer=tok, num_query_tokens=n_query
            )
        except TypeError:  # transformers without image-token expansion in the processor
            processor = processor_cls(image_processor=image_processor, tokenizer=tok)
        image_token = tok.convert_tokens_to_ids("<image>") if "<image>" in tok.get_vocab() else None
        n_vocab = max(text.get("vocab_size", 0), len(tok))
        extra = {} if image_token is None else {"image_token_index": int(image_token)}
        config = _cls("Blip2Config")(
            vision_config=dict(vision),
            qformer_config=dict(qformer, encoder_hidden_size=vision["hidden_size"]),
            text_config=dict(
                text, model_type="opt", vocab_size=n_vocab, bos_token_id=1, eos_token_id=1, pad_token_id=0
            ),
            num_query_tokens=n_query,
            **extra,
        )
        return config, processor

    return make


_TINY_SWIN = dict(
    embed_dim=8,
    depths=[1, 1, 1, 1],
    num_heads=[1, 1, 1, 1],
    window_size=2,
    image_size=64,
    out_indices=[2, 3, 4],
    out_features=["stage2", "stage3", "stage4"],
)
_TINY_BERT = dict(
    vocab_size=0,
    hidden_size=16,
    num_hidden_layers=1,
    num_attention_heads=2,
    intermediate_size=32,
    max_position_embeddings=64,
)

RANDOM_MODELS: dict[str, tuple[str, Callable[[Path], tuple[Any, Any]]]] = {
    # name: (model class, make(folder) -> (config, processor))
    "owlv2-tiny": (
        "Owlv2ForObjectDetection",
        _owl(
            dict(
                vocab_size=0, hidden_size=16, intermediate_size=32, num_hidden_layers=1, num_attention_heads=2
            ),
            dict(
                hidden_size=16,
                intermediate_size=32,
                num_hidden_layers=1,
                num_attention_heads=2,
                image_size=32,
                patch_size=8,
            ),
            projection_dim=16,
            text_len=8,
        ),
    ),
    "grounding-dino-tiny": (
        "GroundingDinoForObjectDetection",
        _gdino(
            _TINY_SWIN,
            _TINY_BERT,
            dict(
                num_queries=20,
                encoder_layers=1,
                decoder_layers=2,
                encoder_ffn_dim=32,
                decoder_ffn_dim=32,
                encoder_attention_heads=2,
                decoder_attention_heads=2,
                d_model=32,
                num_feature_levels=3,
                encoder_n_points=1,
                decoder_n_points=1,
                max_text_len=32,
                disable_custom_kernels=True,
            ),
            {"shortest_edge": 64, "longest_edge": 96},
        ),
    ),
    "blip2-tiny": (
        "Blip2ForConditionalGeneration",
        _blip2(
            dict(
                hidden_size=16,
                intermediate_size=32,
                num_hidden_layers=1,
                num_attention_heads=2,
                image_size=16,
                patch_size=8,
            ),
            dict(
                vocab_size=32,
                hidden_size=16,
                num_hidden_layers=1,
                num_attention_heads=2,
                intermediate_size=32,
                max_position_embeddings=32,
            ),
            dict(
                vocab_size=0,
                hidden_size=16,
                num_hidden_layers=1,
                ffn_dim=32,
                num_attention_heads=2,
                max_position_embeddings=128,
                word_embed_proj_dim=16,
            ),
            n_query=4,
        ),
    ),
    "owlv2-b16": (
        "Owlv2ForObjectDetection",
        _owl(
            dict(
                vocab_size=49408,
                hidden_size=512,
                intermediate_size=2048,
                num_hidden_layers=12,
                num_attention_heads=8,
            ),
            dict(
                hidden_size=768,
                intermediate_size=3072,
                num_hidden_layers=12,
                num_attention_heads=12,
                image_size=960,
                patch_size=16,
            ),
            projection_dim=512,
            text_len=16,
        ),
    ),
    "owlv2-l14": (
        "Owlv2ForObjectDetection",
        _owl(
            dict(
                vocab_size=49408,
                hidden_size=768,
                intermediate_size=3072,
                num_hidden_layers=12,
                num_attention_heads=12,
            ),
            dict(
                hidden_size=1024,
                intermediate_size=4096,
                num_hidden_layers=24,
                num_attention_heads=16,
                image_size=1008,
                patch_size=14,
            ),
            projection_dim=768,
            text_len=16,
        ),
    ),
    "grounding-dino-t": (
        "GroundingDinoForObjectDetection",
        _gdino(
            dict(
                embed_dim=96,
                depths=[2, 2, 6, 2],
                num_heads=[3, 6, 12, 24],
                window_size=7,
                image_size=224,
                out_indices=[2, 3, 4],
                out_features=["stage2", "stage3", "stage4"],
            ),
            dict(
                vocab_size=30522,
                hidden_size=768,
                num_hidden_layers=12,
                num_attention_heads=12,
                intermediate_size=3072,
                max_position_embeddings=512,
            ),
            dict(
                num_queries=900,
                encoder_layers=6,
                decoder_layers=6,
                encoder_ffn_dim=2048,
                decoder_ffn_dim=2048,
                encoder_attention_heads=8,
                decoder_attention_heads=8,
                d_model=256,
                num_feature_levels=4,
                encoder_n_points=4,
                decoder_n_points=4,
                max_text_len=256,
                two_stage=True,
                # the PyTorch deformable attention: the custom CUDA kernel would need compiling or a download
                disable_custom_kernels=True,
            ),
            {"shortest_edge": 800, "longest_edge": 1333},
        ),
    ),
    "blip2-opt-2.7b": (
        "Blip2ForConditionalGeneration",
        _blip2(
            dict(
                hidden_size=1408,
                intermediate_size=6144,
                num_hidden_layers=39,
                num_attention_heads=16,
                image_size=224,
                patch_size=14,
            ),
            dict(
                vocab_size=30522,
                hidden_size=768,
                num_hidden_layers=12,
                num_attention_heads=12,
                intermediate_size=3072,
                max_position_embeddings=512,
                cross_attention_frequency=2,
            ),
            dict(
                vocab_size=50304,
                hidden_size=2560,
                num_hidden_layers=32,
                ffn_dim=10240,
                num_attention_heads=32,
                max_position_embeddings=2048,
                word_embed_proj_dim=2560,
            ),
            n_query=32,
        ),
    ),
}


def build_random(name: str, *, device: str = "cpu", dtype: str = "float32", seed: int = 0) -> tuple[Any, Any]:
    """(model, processor) for `name`, randomly initialised with `seed`, built directly on `device` in `dtype`
    (a 2.7 B model is never materialised in float32 on the CPU first)."""
    if name not in RANDOM_MODELS:
        raise ConfigError(f"no random model called {name!r}", f"choose one of: {', '.join(RANDOM_MODELS)}")
    torch = require("torch", "random transformers models")
    model_class, make = RANDOM_MODELS[name]
    cls = _cls(model_class)
    with tempfile.TemporaryDirectory(prefix="attribot-tok-") as tmp:
        config, processor = make(Path(tmp))
    torch.manual_seed(seed)
    old = torch.get_default_dtype()
    torch.set_default_dtype(getattr(torch, dtype))
    try:
        with torch.device(device):
            model = cls(config)
    finally:
        torch.set_default_dtype(old)
    # parameters made with the legacy `torch.Tensor(...)` constructor ignore the device context
    # (Grounding DINO's `level_embed`): move whatever stayed behind
    return model.to(device).eval(), processor


def save_random(
    name: str, folder: str | Path, *, seed: int = 0, edit: Callable[[Any], None] | None = None
) -> Path:
    """Build `name` (float32, CPU) and save model and processor to `folder`, loadable by path.
    `edit(model)` may change weights first (tests use it to fix a head's output)."""
    model, processor = build_random(name, seed=seed)
    if edit is not None:
        edit(model)
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    model.save_pretrained(str(out))
    processor.save_pretrained(str(out))
    return out
