// Internal: checks on the ONNX models an asset embeds (OXLP, OXDC) before anything hands them to ONNX Runtime.
// See onnx_model.c for what "self-contained" means and why.
#ifndef PLEAT_ONNX_MODEL_H
#define PLEAT_ONNX_MODEL_H
#include <stddef.h>
#include <stdint.h>

typedef enum plOnnxFinding
{
	PLEAT_ONNX_SELF_CONTAINED = 0, // every tensor's data is inside the model and it sets no runtime options
	PLEAT_ONNX_MALFORMED,          // not well-formed protobuf (or nested deeper than PLEAT_ONNX_MAX_DEPTH)
	PLEAT_ONNX_EXTERNAL_DATA,      // a TensorProto with data_location = EXTERNAL or external_data entries
	PLEAT_ONNX_SESSION_CONFIG,     // ModelProto metadata "ort_config": session options chosen by the model
} plOnnxFinding;

// Walks a serialised ONNX ModelProto. Reads only [model, model + size); no allocation; stack depth bounded by
// PLEAT_ONNX_MAX_DEPTH.
plOnnxFinding plOnnxModel_Check( const uint8_t* model, size_t size );

// A short English description of a finding, for log lines.
const char* plOnnxFinding_Describe( plOnnxFinding finding );

#endif
