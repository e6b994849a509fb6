"""The question -> program network: a bidirectional LSTM encoder and an attentional LSTM decoder (NS-VQA).

The decoder emits prefix program tokens; its logits are masked by
:class:`~po3d_ppl.language.seq2seq.constraints.TypeAutomaton` both in training (masked softmax: the model only
learns to choose among tokens that fit) and in decoding. Attention is Luong's "general" score over the encoder
states, applied to the decoder's outputs, so training runs the decoder LSTM over whole sequences at once.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn
from torch.nn.utils.rnn import pack_padded_sequence, pad_packed_sequence


@dataclass(frozen=True)
class ParserConfig:
    """Sizes of the network (stored with the weights)."""

    words: int
    targets: int
    embed: int = 64
    hidden: int = 128
    dropout: float = 0.1
    #: Hash buckets of the character n-gram (subword) embedding; 0 = words only (the first shipped model).
    ngram_buckets: int = 0

    def to_dict(self) -> dict:
        return asdict(self)


class Seq2SeqParser(nn.Module):
    def __init__(self, config: ParserConfig):
        super().__init__()
        self.config = config
        h, e = config.hidden, config.embed
        self.word_embedding = nn.Embedding(config.words, e, padding_idx=0)
        #: Subword input: the mean of a word's hashed character n-gram embeddings is added to its word embedding,
        #: so a word never seen in training (a typo, a plural, a new compound) still reads like its neighbours.
        self.ngram_embedding = (nn.Embedding(config.ngram_buckets, e, padding_idx=0) if config.ngram_buckets
                                else None)
        self.encoder = nn.LSTM(e, h // 2, batch_first=True, bidirectional=True)
        self.bridge = nn.Linear(h, 2 * h)
        self.token_embedding = nn.Embedding(config.targets, e)
        self.decoder = nn.LSTM(e, h, batch_first=True)
        self.attention = nn.Linear(h, h, bias=False)
        self.combine = nn.Linear(2 * h, h)
        self.output = nn.Linear(h, config.targets)
        self.dropout = nn.Dropout(config.dropout)

    def reset_parameters(self, generator: torch.Generator) -> None:
        """Uniform(-0.1, 0.1) initialisation from ``generator`` (no global RNG state is used)."""
        with torch.no_grad():
            for p in self.parameters():
                p.uniform_(-0.1, 0.1, generator=generator)
            self.word_embedding.weight[0].zero_()
            if self.ngram_embedding is not None:
                self.ngram_embedding.weight[0].zero_()

    def embed(self, words: torch.Tensor, ngrams: torch.Tensor | None) -> torch.Tensor:
        """Word embeddings ``[..., E]`` plus, with subword input, the mean of the n-gram embeddings
        (``ngrams`` ``[..., K]``, 0-padded)."""
        embedded = self.word_embedding(words)
        if self.ngram_embedding is not None:
            if ngrams is None:
                raise ValueError("this parser reads character n-grams: pass ngrams")
            count = (ngrams > 0).sum(-1, keepdim=True).clamp(min=1)
            embedded = embedded + self.ngram_embedding(ngrams).sum(-2) / count
        return embedded

    def encode(self, words: torch.Tensor, lengths: torch.Tensor, ngrams: torch.Tensor | None = None):
        """Encoder states ``[B, T, H]``, their padding mask ``[B, T]`` and the decoder's initial (h, c)."""
        embedded = self.dropout(self.embed(words, ngrams))
        packed = pack_padded_sequence(embedded, lengths.cpu(), batch_first=True, enforce_sorted=False)
        states, (h, _) = self.encoder(packed)
        memory, _ = pad_packed_sequence(states, batch_first=True, total_length=words.shape[1])
        summary = torch.cat([h[0], h[1]], dim=-1)  # final forward and backward states
        h0, c0 = torch.tanh(self.bridge(summary)).chunk(2, dim=-1)
        mask = torch.arange(words.shape[1], device=words.device)[None, :] < lengths[:, None].to(words.device)
        return memory, mask, (h0.unsqueeze(0).contiguous(), c0.unsqueeze(0).contiguous())

    def decode(self, tokens: torch.Tensor, state, memory: torch.Tensor, mask: torch.Tensor):
        """Logits ``[B, L, V]`` for the next token after each of ``tokens`` ``[B, L]``, and the new (h, c)."""
        outputs, state = self.decoder(self.dropout(self.token_embedding(tokens)), state)
        scores = torch.einsum("blh,bth->blt", self.attention(outputs), memory)
        scores = scores.masked_fill(~mask[:, None, :], float("-inf"))
        context = torch.einsum("blt,bth->blh", torch.softmax(scores, dim=-1), memory)
        combined = torch.tanh(self.combine(torch.cat([outputs, context], dim=-1)))
        return self.output(self.dropout(combined)), state

    def forward(self, words: torch.Tensor, lengths: torch.Tensor, tokens_in: torch.Tensor,
                ngrams: torch.Tensor | None = None) -> torch.Tensor:
        memory, mask, state = self.encode(words, lengths, ngrams)
        logits, _ = self.decode(tokens_in, state, memory, mask)
        return logits

    # ----- single-question decoding (the latency path) ----------------------------------------------------------
    def step_weights(self) -> StepWeights:
        """The decoder's weights rearranged for :meth:`step` (compute once after loading, in eval mode)."""
        lstm = self.decoder
        return StepWeights(
            embedding=self.token_embedding.weight.detach(),
            gate_weight=torch.cat([lstm.weight_ih_l0, lstm.weight_hh_l0], 1).t().contiguous().detach(),
            gate_bias=(lstm.bias_ih_l0 + lstm.bias_hh_l0).detach(),
            combine_weight=self.combine.weight.t().contiguous().detach(),
            combine_bias=self.combine.bias.detach(),
            output_weight=self.output.weight.t().contiguous().detach(),
            output_bias=self.output.bias.detach(),
        )

    def start(self, words: torch.Tensor, ngrams: torch.Tensor | None = None
              ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """For one question ``words`` ``[T]`` (eval mode): encoder states ``[T, H]``, their attention keys (the
        general-attention projection, applied once instead of at every step) and the initial (h, c) ``[1, H]``."""
        embedded = self.embed(words[None, :], None if ngrams is None else ngrams[None])
        memory, (h, _) = self.encoder(embedded)
        h0, c0 = torch.tanh(self.bridge(torch.cat([h[0], h[1]], dim=-1))).chunk(2, dim=-1)
        memory = memory[0]
        return memory, memory @ self.attention.weight, h0, c0

    @staticmethod
    def step(w: StepWeights, tokens: torch.Tensor, h: torch.Tensor, c: torch.Tensor, memory: torch.Tensor,
             keys: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """One decoder step for ``k`` hypotheses of the same question: ``tokens`` ``[k]``, state ``[k, H]``.

        Written out on pre-arranged weights (one fused gate matmul, no module calls) because at these sizes
        ``nn.LSTM`` and module dispatch cost more per step than the arithmetic; it computes exactly what
        :meth:`decode` computes.
        """
        gates = torch.addmm(w.gate_bias, torch.cat([w.embedding[tokens], h], 1), w.gate_weight)
        i, f, g, o = gates.chunk(4, dim=1)
        c = torch.sigmoid(f) * c + torch.sigmoid(i) * torch.tanh(g)
        h = torch.sigmoid(o) * torch.tanh(c)
        context = torch.softmax(h @ keys.t(), dim=-1) @ memory
        combined = torch.tanh(torch.addmm(w.combine_bias, torch.cat([h, context], 1), w.combine_weight))
        return torch.addmm(w.output_bias, combined, w.output_weight), h, c


@dataclass(frozen=True)
class StepWeights:
    """Decoder weights laid out for single-step decoding (transposed, gates fused)."""

    embedding: torch.Tensor
    gate_weight: torch.Tensor
    gate_bias: torch.Tensor
    combine_weight: torch.Tensor
    combine_bias: torch.Tensor
    output_weight: torch.Tensor
    output_bias: torch.Tensor
