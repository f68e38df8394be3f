"""Two-stage training of the Pleat garment model (paper sections 3.2, 3.3) and the ablation of section 4.3.

    pleat-train stage1   --preset tiny --garment tshirt --out out/train/tiny
    pleat-train stage2   --preset tiny --garment tshirt --out out/train/tiny
    pleat-train pack     --preset tiny --garment tshirt --out out/train/tiny
    pleat-train ablation --preset tiny --garment tshirt --out out/train/tiny

Multi-GPU: `torchrun --nproc_per_node=K -m pleat.train.cli stage1 ...` (DDP). See docs/training.md.
PyTorch is an optional dependency (`pip install pleat-tools[train]`); importing this package does not need it.
"""
