// Stand-in for ort_backend.c when it is not in the tree: the ONNX Runtime backend is unavailable.
#include "ort_backend.h"

plResult plOrtMlp_Create( const char* library_path, const void* onnx_model, size_t onnx_model_size,
						  uint32_t input_count, uint32_t output_count, const plAllocator* allocator, plOrtMlp** out )
{
	(void)library_path;
	(void)onnx_model;
	(void)onnx_model_size;
	(void)input_count;
	(void)output_count;
	(void)allocator;
	if ( out != NULL )
	{
		*out = NULL;
	}
	return PLEAT_RESULT_BACKEND_UNAVAILABLE;
}

plResult plOrtMlp_Run( plOrtMlp* mlp, const float* input, float* output )
{
	(void)mlp;
	(void)input;
	(void)output;
	return PLEAT_RESULT_BACKEND_UNAVAILABLE;
}

void plOrtMlp_Destroy( plOrtMlp* mlp )
{
	(void)mlp;
}
