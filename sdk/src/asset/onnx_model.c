// Checks on the ONNX models an asset embeds (OXLP, OXDC), run by the loader on every asset and again by the ONNX
// Runtime backend before it creates a session.
//
// Why: an ONNX model may keep a tensor's bytes outside itself (TensorProto.data_location = EXTERNAL with external_data
// entries location / offset / length), and ONNX Runtime, given a model as bytes, resolves such a location against the
// process's working directory: an asset could make the runtime read any file the process can read and use it as
// weights. A model's "ort_config" metadata can likewise set session options (profiling, which writes a
// file) where the host has ORT_LOAD_CONFIG_FROM_MODEL set. A Pleat asset is self-contained by definition — pleat-pack
// embeds every weight inline and writes no such metadata — so a model that does either is rejected, not repaired.
//
// How: the model is walked as protobuf wire format (key = field << 3 | wire type; varint, 64-bit, length-delimited
// and 32-bit values). Every message that can hold a TensorProto, directly or through a subgraph, is descended into,
// following onnx.proto's field numbers; every other length-delimited field is skipped as opaque bytes, since no other
// ONNX message holds a tensor. Anything the walk cannot read — a length past the end, a varint over 10 bytes, a group
// (ONNX never writes one), nesting deeper than PLEAT_ONNX_MAX_DEPTH — is MALFORMED: what cannot be walked cannot be
// shown to stay inside the asset. Every byte is visited once, so the walk is linear in the model's size.
#include "onnx_model.h"

#include <string.h>

// Messages nested deeper than this are rejected (protobuf's own default limit is 100). An exported MLP nests four
// deep (model → graph → node → attribute → tensor); each control-flow subgraph adds three.
#define PLEAT_ONNX_MAX_DEPTH 64

// The ONNX messages the walk descends into (onnx.proto), and OPAQUE for bytes it only skips.
typedef enum plOnnxMessage
{
	PLEAT_ONNX_OPAQUE = 0,
	PLEAT_ONNX_MODEL,
	PLEAT_ONNX_GRAPH,
	PLEAT_ONNX_NODE,
	PLEAT_ONNX_ATTRIBUTE,
	PLEAT_ONNX_TENSOR,
	PLEAT_ONNX_SPARSE_TENSOR,
	PLEAT_ONNX_TRAINING_INFO,
	PLEAT_ONNX_FUNCTION,
	PLEAT_ONNX_MODEL_METADATA, // StringStringEntryProto in ModelProto.metadata_props
} plOnnxMessage;

// The message a length-delimited field of `parent` holds, by field number (onnx.proto).
static plOnnxMessage plOnnxChild( plOnnxMessage parent, uint64_t field )
{
	switch ( parent )
	{
		case PLEAT_ONNX_MODEL: // graph = 7, metadata_props = 14, training_info = 20, functions = 25
			return field == 7    ? PLEAT_ONNX_GRAPH
				   : field == 14 ? PLEAT_ONNX_MODEL_METADATA
				   : field == 20 ? PLEAT_ONNX_TRAINING_INFO
				   : field == 25 ? PLEAT_ONNX_FUNCTION
								 : PLEAT_ONNX_OPAQUE;
		case PLEAT_ONNX_GRAPH: // node = 1, initializer = 5, sparse_initializer = 15
			return field == 1    ? PLEAT_ONNX_NODE
				   : field == 5  ? PLEAT_ONNX_TENSOR
				   : field == 15 ? PLEAT_ONNX_SPARSE_TENSOR
								 : PLEAT_ONNX_OPAQUE;
		case PLEAT_ONNX_NODE: // attribute = 5
			return field == 5 ? PLEAT_ONNX_ATTRIBUTE : PLEAT_ONNX_OPAQUE;
		case PLEAT_ONNX_ATTRIBUTE: // t = 5, tensors = 10; g = 6, graphs = 11; sparse_tensor = 22, sparse_tensors = 23
			return ( field == 5 || field == 10 )    ? PLEAT_ONNX_TENSOR
				   : ( field == 6 || field == 11 )  ? PLEAT_ONNX_GRAPH
				   : ( field == 22 || field == 23 ) ? PLEAT_ONNX_SPARSE_TENSOR
													: PLEAT_ONNX_OPAQUE;
		case PLEAT_ONNX_SPARSE_TENSOR: // values = 1, indices = 2
			return ( field == 1 || field == 2 ) ? PLEAT_ONNX_TENSOR : PLEAT_ONNX_OPAQUE;
		case PLEAT_ONNX_TRAINING_INFO: // initialization = 1, algorithm = 2
			return ( field == 1 || field == 2 ) ? PLEAT_ONNX_GRAPH : PLEAT_ONNX_OPAQUE;
		case PLEAT_ONNX_FUNCTION: // node = 7, attribute_proto = 11
			return field == 7 ? PLEAT_ONNX_NODE : field == 11 ? PLEAT_ONNX_ATTRIBUTE : PLEAT_ONNX_OPAQUE;
		default:
			return PLEAT_ONNX_OPAQUE;
	}
}

// Reads a base-128 varint of at most 64 bits; 0 if it runs past end or is longer.
static int plOnnxReadVarint( const uint8_t** cursor, const uint8_t* end, uint64_t* out )
{
	uint64_t value = 0;
	for ( uint32_t shift = 0; shift < 64; shift += 7 )
	{
		if ( *cursor == end )
		{
			return 0;
		}
		uint8_t byte = *( *cursor )++;
		if ( shift == 63 && byte > 1 ) // the tenth byte has room for one bit and no continuation
		{
			return 0;
		}
		value |= (uint64_t)( byte & 0x7Fu ) << shift;
		if ( ( byte & 0x80u ) == 0 )
		{
			*out = value;
			return 1;
		}
	}
	return 0;
}

// TensorProto: external_data = 13 (repeated StringStringEntryProto), data_location = 14 (enum, EXTERNAL = 1).
// ModelProto.metadata_props entry: key = 1.
static plOnnxFinding plOnnxWalk( const uint8_t* cursor, const uint8_t* end, plOnnxMessage message, uint32_t depth )
{
	if ( depth > PLEAT_ONNX_MAX_DEPTH )
	{
		return PLEAT_ONNX_MALFORMED;
	}
	while ( cursor < end )
	{
		uint64_t key = 0;
		if ( !plOnnxReadVarint( &cursor, end, &key ) )
		{
			return PLEAT_ONNX_MALFORMED;
		}
		uint64_t field = key >> 3;
		if ( field == 0 || field > 0x1FFFFFFFu ) // protobuf field numbers are 1 .. 2^29 − 1
		{
			return PLEAT_ONNX_MALFORMED;
		}
		switch ( key & 7u )
		{
			case 0: // varint
			{
				uint64_t value = 0;
				if ( !plOnnxReadVarint( &cursor, end, &value ) )
				{
					return PLEAT_ONNX_MALFORMED;
				}
				if ( message == PLEAT_ONNX_TENSOR && field == 14 && value != 0 )
				{
					return PLEAT_ONNX_EXTERNAL_DATA;
				}
				break;
			}
			case 1: // 64-bit
				if ( end - cursor < 8 )
				{
					return PLEAT_ONNX_MALFORMED;
				}
				cursor += 8;
				break;
			case 5: // 32-bit
				if ( end - cursor < 4 )
				{
					return PLEAT_ONNX_MALFORMED;
				}
				cursor += 4;
				break;
			case 2: // length-delimited
			{
				uint64_t length = 0;
				if ( !plOnnxReadVarint( &cursor, end, &length ) || length > (uint64_t)( end - cursor ) )
				{
					return PLEAT_ONNX_MALFORMED;
				}
				const uint8_t* body = cursor;
				cursor += length;
				// Any external_data entry, even with data_location left DEFAULT, and data_location in any encoding
				// but the plain varint 0: nothing in a Pleat asset has a reason to carry either.
				if ( message == PLEAT_ONNX_TENSOR && ( field == 13 || field == 14 ) )
				{
					return PLEAT_ONNX_EXTERNAL_DATA;
				}
				if ( message == PLEAT_ONNX_MODEL_METADATA && field == 1 && length == 10 &&
					 memcmp( body, "ort_config", 10 ) == 0 )
				{
					return PLEAT_ONNX_SESSION_CONFIG;
				}
				plOnnxMessage child = plOnnxChild( message, field );
				if ( child != PLEAT_ONNX_OPAQUE )
				{
					plOnnxFinding finding = plOnnxWalk( body, cursor, child, depth + 1 );
					if ( finding != PLEAT_ONNX_SELF_CONTAINED )
					{
						return finding;
					}
				}
				break;
			}
			default: // groups (3, 4) and the undefined 6, 7
				return PLEAT_ONNX_MALFORMED;
		}
	}
	return PLEAT_ONNX_SELF_CONTAINED;
}

plOnnxFinding plOnnxModel_Check( const uint8_t* model, size_t size )
{
	if ( model == NULL || size == 0 )
	{
		return PLEAT_ONNX_MALFORMED;
	}
	return plOnnxWalk( model, model + size, PLEAT_ONNX_MODEL, 0 );
}

const char* plOnnxFinding_Describe( plOnnxFinding finding )
{
	switch ( finding )
	{
		case PLEAT_ONNX_SELF_CONTAINED:
			return "self-contained";
		case PLEAT_ONNX_MALFORMED:
			return "not a well-formed ONNX model (protobuf)";
		case PLEAT_ONNX_EXTERNAL_DATA:
			return "a tensor keeps its data outside the model (data_location = EXTERNAL / external_data location)";
		case PLEAT_ONNX_SESSION_CONFIG:
			return "metadata 'ort_config' would set ONNX Runtime session options";
	}
	return "unknown finding";
}
