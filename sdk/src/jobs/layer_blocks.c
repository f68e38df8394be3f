// Block-structured layers: rows whose weights are zero outside one column window are multiplied over that window only.
// A packed ensemble (pleat.train.ensemble: two member fits side by side as one large network) has block-diagonal
// hidden and output layers, so half of its multiply-adds are 0 · x; found here once at load, they are skipped, and the
// ensemble costs about what its members cost instead of what a dense network of its sizes costs. The windows are
// widened to 16-column boundaries so each kernel's FMA chains over a window are those of the whole row: the results
// are the dense product's bits (the skipped terms are exact zeros; tests/c/test_layer_blocks.c).
#include "kernels/kernels.h"

#include <string.h>

uint32_t plLayerBlocks( const plLayer* layer, plLayerBlock* blocks )
{
	if ( layer->block_count == 0 || layer->block_count > PLEAT_MAX_LAYER_BLOCKS )
	{
		blocks[0] = ( plLayerBlock ){ 0, layer->out_count, 0, layer->in_count };
		return 1;
	}
	for ( uint32_t i = 0; i < layer->block_count; ++i )
	{
		blocks[i] = layer->blocks[i];
	}
	return layer->block_count;
}

uint64_t plLayerMacs( const plLayer* layer )
{
	plLayerBlock blocks[PLEAT_MAX_LAYER_BLOCKS];
	uint32_t count = plLayerBlocks( layer, blocks );
	uint64_t macs = 0;
	for ( uint32_t i = 0; i < count; ++i )
	{
		macs += (uint64_t)( blocks[i].row_end - blocks[i].row_begin ) * ( blocks[i].col_end - blocks[i].col_begin );
	}
	return macs;
}

static int plWeightIsZero( const plLayer* layer, size_t index )
{
	if ( layer->weight_int8 )
	{
		return ( (const int8_t*)layer->weight )[index] == 0;
	}
	if ( layer->weight_fp16 )
	{
		return ( ( (const uint16_t*)layer->weight )[index] & 0x7fffu ) == 0; // +0 or −0
	}
	return ( (const float*)layer->weight )[index] == 0.0f;
}

// The column window of rows [row_begin, row_end): the smallest [16 a, min(16 b, in_count)) holding every non-zero
// weight of those rows; empty (0, 0) when all of them are zero.
static plLayerBlock plRowWindow( const plLayer* layer, uint32_t row_begin, uint32_t row_end )
{
	uint32_t in = layer->in_count, first = in, last = 0;
	for ( uint32_t r = row_begin; r < row_end; ++r )
	{
		size_t row = (size_t)r * in;
		uint32_t c = 0;
		while ( c < in && plWeightIsZero( layer, row + c ) )
		{
			++c;
		}
		if ( c == in )
		{
			continue; // an all-zero row: any window gives its bias
		}
		first = c < first ? c : first;
		c = in;
		while ( c > last && plWeightIsZero( layer, row + c - 1 ) )
		{
			--c;
		}
		last = c > last ? c : last;
	}
	if ( first >= last )
	{
		return ( plLayerBlock ){ row_begin, row_end, 0, 0 };
	}
	uint32_t col_begin = first & ~15u, col_end = ( last + 15u ) & ~15u;
	return ( plLayerBlock ){ row_begin, row_end, col_begin, col_end < in ? col_end : in };
}

void plFindLayerBlocks( plLayer* layer )
{
	layer->block_count = 0;
	uint64_t dense = (uint64_t)layer->out_count * layer->in_count;
	uint64_t best = dense - dense / 4; // a split must save at least a quarter of the multiply-adds
	static const uint32_t parts[5] = { 2, 3, 4, 6, 8 }; // ensembles of 2–8 members; 6 is not a power of two
	for ( int p = 0; p < 5; ++p )
	{
		uint32_t n = parts[p];
		if ( n > PLEAT_MAX_LAYER_BLOCKS || layer->out_count % n != 0 )
		{
			continue;
		}
		uint32_t rows = layer->out_count / n;
		plLayerBlock blocks[PLEAT_MAX_LAYER_BLOCKS];
		uint64_t cost = 0;
		for ( uint32_t i = 0; i < n; ++i )
		{
			blocks[i] = plRowWindow( layer, i * rows, ( i + 1 ) * rows );
			cost += (uint64_t)rows * ( blocks[i].col_end - blocks[i].col_begin );
		}
		if ( cost < best )
		{
			best = cost;
			layer->block_count = n;
			for ( uint32_t i = 0; i < n; ++i )
			{
				layer->blocks[i] = blocks[i];
			}
		}
	}
}

size_t plPackedLayerBytes( const plLayer* layer )
{
	if ( layer->block_count < 2 || layer->block_count > PLEAT_MAX_LAYER_BLOCKS )
	{
		return 0;
	}
	uint32_t width = layer->blocks[0].col_end - layer->blocks[0].col_begin;
	for ( uint32_t i = 1; i < layer->block_count; ++i )
	{
		if ( layer->blocks[i].col_end - layer->blocks[i].col_begin != width )
		{
			return 0; // ragged windows: the kernels' tails would differ between blocks of one stride
		}
	}
	return (size_t)layer->out_count * width * plWeightBytes( layer );
}

void plPackLayer( plLayer* layer, void* dst )
{
	size_t element = plWeightBytes( layer );
	uint32_t width = layer->blocks[0].col_end - layer->blocks[0].col_begin;
	for ( uint32_t i = 0; i < layer->block_count; ++i )
	{
		const plLayerBlock* b = &layer->blocks[i];
		for ( uint32_t r = b->row_begin; r < b->row_end; ++r )
		{
			memcpy( (uint8_t*)dst + (size_t)r * width * element,
					(const uint8_t*)layer->weight + ( (size_t)r * layer->in_count + b->col_begin ) * element,
					width * element );
		}
	}
	layer->packed = dst;
	layer->packed_width = width;
}
