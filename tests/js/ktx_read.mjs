// Reads a KTX2 file with ktx-parse (an implementation independent of raywarp's) and prints what
// it found as one JSON object: the header fields, the key/value data in file order (values as
// UTF-8 text up to their trailing NUL, and as hex), the Basic DFD's parsed fields, and level 0's
// byteLength, uncompressedByteLength and bytes (hex), so a test can compare them bit-exactly.
// Usage: node ktx_read.mjs FILE.ktx2   (exit status 1 and a message on stderr if unreadable)
import { readFileSync } from 'node:fs';
import { read } from 'ktx-parse';

const hex = (bytes) => Buffer.from(bytes.buffer, bytes.byteOffset, bytes.byteLength).toString('hex');

function main(path) {
  const container = read(new Uint8Array(readFileSync(path)));
  const keyValues = Object.entries(container.keyValue).map(([key, value]) => {
    // ktx-parse decodes values of "KTX"/"ktx" keys to text (without the NUL); others stay bytes.
    if (typeof value === 'string') return { key, text: value, hex: Buffer.from(value, 'utf8').toString('hex') };
    const nul = value.indexOf(0);
    const text = Buffer.from(value.subarray(0, nul < 0 ? value.length : nul)).toString('utf8');
    return { key, text, hex: hex(value) };
  });
  const dfd = container.dataFormatDescriptor.map((d) => ({
    vendorId: d.vendorId,
    descriptorType: d.descriptorType,
    versionNumber: d.versionNumber,
    colorModel: d.colorModel,
    colorPrimaries: d.colorPrimaries,
    transferFunction: d.transferFunction,
    flags: d.flags,
    texelBlockDimension: d.texelBlockDimension,
    bytesPlane: d.bytesPlane,
    samples: d.samples.map((s) => ({
      bitOffset: s.bitOffset,
      bitLength: s.bitLength,
      channelType: s.channelType,
      samplePosition: s.samplePosition,
      // As uint32 bit patterns (ktx-parse reads them as int32 for signed samples).
      sampleLower: s.sampleLower >>> 0,
      sampleUpper: s.sampleUpper >>> 0,
    })),
  }));
  const levels = container.levels.map((l) => ({
    byteLength: l.levelData.byteLength,
    uncompressedByteLength: l.uncompressedByteLength,
    hex: hex(l.levelData),
  }));
  const out = {
    reader: 'ktx-parse',
    vkFormat: container.vkFormat,
    typeSize: container.typeSize,
    pixelWidth: container.pixelWidth,
    pixelHeight: container.pixelHeight,
    pixelDepth: container.pixelDepth,
    layerCount: container.layerCount,
    faceCount: container.faceCount,
    levelCount: container.levelCount,
    supercompressionScheme: container.supercompressionScheme,
    keyValues,
    dataFormatDescriptor: dfd,
    levels,
  };
  process.stdout.write(JSON.stringify(out) + '\n');
}

if (process.argv.length !== 3) {
  process.stderr.write('usage: node ktx_read.mjs FILE.ktx2\n');
  process.exit(2);
}
try {
  main(process.argv[2]);
} catch (e) {
  process.stderr.write(`ktx_read: ${process.argv[2]}: ${e.message}\n`);
  process.exit(1);
}
