# asn1c 0.9.28's uPER encoders of OCTET STRING and SEQUENCE OF end a fragmented length (X.691
# §11.9.3.8: 16K, 32K, 48K or 64K items per fragment) without the final length that must follow
# the last fragment when the count is a multiple of 16384 (a zero length): a 256x256 mono8 image
# (65536 bytes) or a 16384-point cloud encodes to bytes that every uPER decoder, asn1c's own
# included, reads as truncated. This script, run on the generated runtime, adds that length. It
# fails when the code is not asn1c 0.9.28's (a later asn1c: check whether it still needs it).
# Usage: cmake -DDIR=<generated dir> -P fix_fragments.cmake
function(replace_once file from to)
  file(READ ${file} text)
  string(FIND "${text}" "${from}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "fix_fragments.cmake: ${file} does not hold the code of asn1c 0.9.28 "
                        "that it fixes:\n${from}")
  endif()
  string(REPLACE "${from}" "${to}" text "${text}")
  file(WRITE ${file} "${text}")
endfunction()

replace_once(${DIR}/OCTET_STRING.c
  "	buf = st->buf;\n	while(sizeinunits) {"
  "	buf = st->buf;\n	/* CDFF: a multiple of 16K ends with a zero length (fix_fragments.cmake) */\n	const int cdff_ends_with_fragment = sizeinunits >= 16384 && sizeinunits % 16384 == 0;\n	while(sizeinunits) {")
replace_once(${DIR}/OCTET_STRING.c
  "		assert(!(maySave & 0x07) || !sizeinunits);\n	}\n\n	ASN__ENCODED_OK(er);"
  "		assert(!(maySave & 0x07) || !sizeinunits);\n	}\n	if(cdff_ends_with_fragment && uper_put_length(po, 0))\n		ASN__ENCODE_FAILED;\n\n	ASN__ENCODED_OK(er);")
replace_once(${DIR}/constr_SEQUENCE_OF.c
  "			if(er.encoded == -1)\n				ASN__ENCODE_FAILED;\n		}\n	}\n\n	ASN__ENCODED_OK(er);"
  "			if(er.encoded == -1)\n				ASN__ENCODE_FAILED;\n		}\n	}\n	/* CDFF: a multiple of 16K ends with a zero length (fix_fragments.cmake) */\n	if(!(ct && ct->effective_bits >= 0) && list->count >= 16384\n			&& list->count % 16384 == 0 && uper_put_length(po, 0))\n		ASN__ENCODE_FAILED;\n\n	ASN__ENCODED_OK(er);")
