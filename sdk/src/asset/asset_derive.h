// Internal: what the load derives from a parsed asset for the context's kernels (docs/architecture.md, "One step").
#ifndef PLEAT_ASSET_DERIVE_H
#define PLEAT_ASSET_DERIVE_H
#include "asset_data.h"
#include "core/core.h"

#include <stddef.h>

// The derived block (asset->derived_block, from the context's allocator): the single step's packed copies of the
// networks' block layers (plLayer.packed), the body's rings in lanes (plRingLanes), the contact candidates as posed
// rows' offsets (plContactRowOffsets) and the skin indices as column-block offsets (plSkinColumnOffsets).
// PLEAT_RESULT_OUT_OF_MEMORY if it cannot be allocated.
plResult plDeriveKernelData( plContextData* ctx, plAssetData* asset );
// Floats of a context scratch block plStepInstances's wide forms need for the asset with the context's batched
// kernels (0: none).
size_t plBatchScratchFloats( const plContextData* ctx, const plAssetData* a );

#endif
