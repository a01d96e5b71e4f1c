"""Training of the learned parts (needs the ``train`` extra: PyTorch, onnx)."""
