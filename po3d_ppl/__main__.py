from po3d_ppl.cli import main

main()
