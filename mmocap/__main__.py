from mmocap.cli import main

main()
