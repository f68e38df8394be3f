// Internal contract between the instance and the optional ONNX Runtime backend (ort_backend.c).
// libonnxruntime is loaded at run time with dlopen; nothing links against it. The ONNX models are the asset's
// optional OXLP (latent predictor: x normalised [I] → y [L]) and OXDC (decoder: Z [L] → w [D]) sections, written by
// `pleat-pack --onnx`. Anything missing (library, symbol, section, header at build time) → PLEAT_RESULT_BACKEND_UNAVAILABLE.
#ifndef PLEAT_ORT_BACKEND_H
#define PLEAT_ORT_BACKEND_H
#include "core/allocator.h"
#include "pleat/pleat.h"
#include <stddef.h>
#include <stdint.h>

typedef struct plOrtMlp plOrtMlp;

// library_path: NULL = search $PLEAT_ONNXRUNTIME_LIBRARY, then "libonnxruntime.so", then "libonnxruntime.so.1".
// The library is loaded once per process and reference counted. Sessions use one intra-op thread and no inter-op
// threads (the host's task system owns parallelism). One input and one output tensor of shape [1, count], fp32.
// A model that is not self-contained (onnx_model.h: external tensor data, session config) is INVALID_ASSET_DATA
// before ONNX Runtime sees it.
plResult plOrtMlp_Create( const char* library_path, const void* onnx_model, size_t onnx_model_size,
						  uint32_t input_count, uint32_t output_count, const plAllocator* allocator, plOrtMlp** out );
plResult plOrtMlp_Run( plOrtMlp* mlp, const float* input, float* output );
void plOrtMlp_Destroy( plOrtMlp* mlp );
// After plOrtMlp_Create failed with BACKEND_UNAVAILABLE: writes why into out (NUL-terminated) for the log — the
// library not found (naming what was tried and PLEAT_ONNXRUNTIME_LIBRARY), too old, or the SDK built without the
// header. Returns 0 and writes "" when the library is loaded and usable (the failure was elsewhere).
int plOrtMlp_DescribeUnavailable( const char* library_path, char* out, size_t out_size );

#endif
